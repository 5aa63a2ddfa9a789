//! Queues at red lights (0-15 m/s, standstill gaps 1.5-4 m): approaching a standing queue,
//! stop-and-go and creeping behind a leader, queues side by side in adjacent lanes, and the
//! rear-end conflicts of queues (inattentive approach; an eager start into a leader that stops
//! again).
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::parts::{
    agent, distracted_until, driver, roles, scripted, sign, u, Built, Vehicle, CRUISE,
};
use crate::sim::world::{Driver, FollowLaw, Path, Piece};

/// Fastest queue speed (m/s): urban arterial traffic between red lights.
const V_QUEUE: f64 = 15.0;

/// A queue driver: the follower of the original families with a standstill gap of 1.5-4 m and
/// the ACC following law (IDM alone brakes harder than queue drivers do when closing in on a
/// standing queue end from 5-15 m/s).
fn queue_driver(rng: &mut ChaCha8Rng, hz: bool, v: f64) -> Driver {
    let mut d = driver(rng, hz, v.max(1.0), (1.0, 1.08));
    d.law = FollowLaw::Acc;
    d.v0 = d.v0.min(V_QUEUE);
    d.s0 = u(rng, 1.5, 4.0);
    d.swerve = None;
    d
}

/// A vehicle moving through the queue from speed `v` until `horizon`: moves off at 0.6-1.5 m/s^2
/// to 2-10 m/s (or creeps at 0.5-1.5 m/s) for 2-7 s, brakes at 0.6-1.5 m/s^2 to a stop (or, one
/// time in five, to a crawl of 0.3-1 m/s), waits 2-6 s after coming to rest, moves off again.
fn stop_and_go(rng: &mut ChaCha8Rng, v: f64, t0: f64, horizon: f64) -> Vec<(f64, Piece)> {
    let mut pieces = vec![(0.0, CRUISE)];
    let (mut t, mut v) = (t0, v);
    while t < horizon {
        let v_go = if rng.random_bool(0.25) {
            u(rng, 0.5, 1.5)
        } else {
            u(rng, 2.0, 10.0)
        };
        let (a, t_go) = (u(rng, 0.6, 1.5), u(rng, 2.0, 7.0));
        pieces.push((
            t,
            Piece::Accel {
                a,
                v_lo: 0.0,
                v_hi: v_go,
            },
        ));
        t += t_go;
        v = if v < v_go {
            (v + a * t_go).min(v_go)
        } else {
            v
        };
        let v_stop = if rng.random_bool(0.2) {
            u(rng, 0.3, 1.0)
        } else {
            0.0
        };
        let d = u(rng, 0.6, 1.5);
        pieces.push((
            t,
            Piece::Accel {
                a: -d,
                v_lo: v_stop,
                v_hi: f64::MAX,
            },
        ));
        t += (v - v_stop).max(0.0) / d + u(rng, 2.0, 6.0);
        v = v_stop.min(v);
    }
    pieces
}

/// Follower F behind leader L in a queue at a red light (ego is the follower with p = 0.75).
/// Benign: F approaches the standing queue and stops behind it, then both move off on green;
/// F follows L through stop-and-go and creeping; or the two stand and move in adjacent queues
/// (partner beside the ego at 3-7 m centre distance). Hazardous: F approaches the queue
/// inattentive and brakes late; or F, standing behind L, starts eagerly when L moves off and
/// looks at the signal while L stops again.
pub(super) fn signal_queue(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> Built {
    let (ego_follows, fv, lv) = roles(rng, 0.75, ego, partner);
    let width = u(rng, 3.0, 3.6);
    let half_lengths = 0.5 * (fv.dims.0 + lv.dims.0);
    let road = Path::line(0.0, 0.0, 0.0);
    let variant: f64 = rng.random();
    if !hz && variant < 0.25 {
        // Adjacent queues: neither is the other's leader; each moves with its own signal phase.
        let horizon = u(rng, 12.0, 22.0);
        let (v_f, v_l) = (u(rng, 0.0, 6.0), u(rng, 0.0, 6.0));
        let (t_f, t_l) = (u(rng, 0.5, 3.0), u(rng, 0.5, 3.0));
        let f_pieces = stop_and_go(rng, v_f, t_f, horizon);
        let l_pieces = stop_and_go(rng, v_l, t_l, horizon);
        let (fd, fs) = scripted(rng, v_f, f_pieces);
        let (ld, ls) = scripted(rng, v_l, l_pieces);
        let mut f = agent(road, 0.0, v_f, fv, fd);
        f.script = Some(fs);
        let lateral = sign(rng) * width;
        let mut l = agent(
            Path::line(0.0, lateral, 0.0),
            u(rng, -8.0, 8.0),
            v_l,
            lv,
            ld,
        );
        l.script = Some(ls);
        return (f, l, horizon, ego_follows);
    }
    let lanes = (fv, lv, half_lengths);
    if !hz && variant < 0.6 {
        // Approach to the standing queue end, stop, move off on green.
        let v = u(rng, 5.0, V_QUEUE);
        let fd = queue_driver(rng, false, v);
        let gap0 = fd.s0 + v * u(rng, 4.0, 8.0);
        let t_green = u(rng, 10.0, 16.0);
        let pieces = vec![
            (0.0, CRUISE),
            (
                t_green,
                Piece::Accel {
                    a: u(rng, 0.8, 1.5),
                    v_lo: 0.0,
                    v_hi: u(rng, 5.0, V_QUEUE),
                },
            ),
        ];
        let horizon = t_green + u(rng, 4.0, 8.0);
        finish(
            rng,
            lanes,
            (v, fd, gap0),
            (0.0, pieces),
            (horizon, ego_follows),
        )
    } else if !hz {
        // Stop-and-go behind the leader, both moving at the same speed at the follower's gap.
        let v = u(rng, 0.0, 6.0);
        let fd = queue_driver(rng, false, v);
        let gap0 = fd.s0 + v * fd.headway;
        let horizon = u(rng, 15.0, 25.0);
        let t_first = u(rng, 0.5, 3.0);
        let pieces = stop_and_go(rng, v, t_first, horizon);
        finish(
            rng,
            lanes,
            (v, fd, gap0),
            (v, pieces),
            (horizon, ego_follows),
        )
    } else if variant < 0.55 {
        // Inattentive approach to the standing (or creeping) queue end.
        let v = u(rng, 6.0, V_QUEUE);
        let mut fd = queue_driver(rng, true, v);
        let t_enc = u(rng, 6.5, 10.0);
        let wake = u(rng, 0.6, 3.0);
        distracted_until(&mut fd, t_enc - wake);
        let creep = if rng.random_bool(0.3) {
            u(rng, 0.5, 1.5)
        } else {
            0.0
        };
        let gap0 = (v - creep) * t_enc + fd.s0;
        let horizon = t_enc + u(rng, 2.0, 4.0);
        let pieces = vec![(0.0, CRUISE)];
        finish(
            rng,
            lanes,
            (v, fd, gap0),
            (creep, pieces),
            (horizon, ego_follows),
        )
    } else {
        // Both standing; the leader moves off and stops again hard; the follower moves off
        // eagerly and watches the signal instead of the leader.
        let mut fd = queue_driver(rng, true, 0.0);
        fd.v0 = u(rng, 8.0, V_QUEUE);
        fd.a_max = u(rng, 1.5, 2.5);
        let t_go = u(rng, 4.5, 7.0);
        let t_stop = t_go + u(rng, 1.5, 4.0);
        let look = t_go + fd.tau + u(rng, 0.0, 1.0);
        fd.distraction.push((look, look + u(rng, 1.0, 2.5)));
        let pieces = vec![
            (0.0, CRUISE),
            (
                t_go,
                Piece::Accel {
                    a: u(rng, 1.2, 2.0),
                    v_lo: 0.0,
                    v_hi: u(rng, 4.0, 9.0),
                },
            ),
            (
                t_stop,
                Piece::Accel {
                    a: -u(rng, 3.0, 7.0),
                    v_lo: 0.0,
                    v_hi: f64::MAX,
                },
            ),
        ];
        let gap0 = fd.s0;
        let horizon = t_stop + u(rng, 3.0, 5.0);
        finish(
            rng,
            lanes,
            (0.0, fd, gap0),
            (0.0, pieces),
            (horizon, ego_follows),
        )
    }
}

/// The follower and the scripted leader of a same-lane queue variant.
fn finish(
    rng: &mut ChaCha8Rng,
    (fv, lv, half_lengths): (&Vehicle, &Vehicle, f64),
    (v_f, fd, gap0): (f64, Driver, f64),
    (v_l, pieces): (f64, Vec<(f64, Piece)>),
    (horizon, ego_follows): (f64, bool),
) -> Built {
    let road = Path::line(0.0, 0.0, 0.0);
    let (ld, script) = scripted(rng, v_l, pieces);
    let f = agent(road.clone(), 0.0, v_f, fv, fd);
    let mut l = agent(road, gap0 + half_lengths, v_l, lv, ld);
    l.script = Some(script);
    (f, l, horizon, ego_follows)
}
