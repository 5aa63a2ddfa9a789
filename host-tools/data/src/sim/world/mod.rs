//! The two-vehicle world: each vehicle's state and the integration that advances both.
//!
//! Each vehicle moves along a reference path (straight lines and circular arcs, [`path`]) with a
//! lateral offset `d(s)` that is a smooth (quintic) function of the distance travelled, so heading
//! always equals the direction of motion and a vehicle never moves sideways while standing.
//! Longitudinal motion is the driver's commanded acceleration ([`driver`]: IDM with reaction delay,
//! or a script; [`conflict`]: yielding at crossings), applied through a jerk limit and the
//! vehicle's physical acceleration/braking limits.
mod conflict;
mod driver;
mod path;

use conflict::{conflict_stop, CrossingProgress};
pub(crate) use conflict::{conflict_zone, Conflict, Role};
pub(crate) use driver::{Driver, FollowLaw, LatPlan, Piece, Script, Snap, Swerve, Trigger};
pub(crate) use path::{lateral_len, Handling, Lateral, Path, Seg};
use scorer_core::VehicleState;

/// Integration step (s): 5 sub-steps per 10 Hz frame.
pub(crate) const DT: f64 = 0.02;
pub(crate) const SUBSTEPS: usize = 5;
pub(crate) const FRAME_DT: f64 = DT * SUBSTEPS as f64;

/// One simulated vehicle.
#[derive(Clone, Debug)]
pub(crate) struct Agent {
    pub path: Path,
    pub lat: Lateral,
    pub s: f64,
    pub v: f64,
    pub a: f64,
    pub length: f64,
    pub width: f64,
    /// Physical limits (m/s^2): tyre-road braking and engine acceleration.
    pub b_phys: f64,
    pub a_phys: f64,
    /// Lateral limits: every lateral move is sized within them (`lateral_len`).
    pub handling: Handling,
    pub driver: Driver,
    pub script: Option<Script>,
    pub plans: Vec<LatPlan>,
    pub conflict: Option<Conflict>,
    held_cmd: f64,
    swerved: bool,
    crossing: CrossingProgress,
    /// Time to contact (s) with the leader in the lane as last perceived (infinite: none, or not
    /// closing in); it fires [`Trigger::Ttc`] plans.
    seen_ttc: f64,
}

impl Agent {
    pub fn new(
        path: Path,
        s: f64,
        v: f64,
        dims: (f64, f64),
        limits: (f64, f64),
        handling: Handling,
        driver: Driver,
    ) -> Self {
        Self {
            path,
            lat: Lateral::default(),
            s,
            v,
            a: 0.0,
            length: dims.0,
            width: dims.1,
            b_phys: limits.0,
            a_phys: limits.1,
            handling,
            driver,
            script: None,
            plans: Vec::new(),
            conflict: None,
            held_cmd: 0.0,
            swerved: false,
            crossing: CrossingProgress::default(),
            seen_ttc: f64::INFINITY,
        }
    }

    pub fn snap(&self) -> Snap {
        let p = self.path.pose(self.s);
        let (c, sn) = (p.psi.cos(), p.psi.sin());
        let (d, d1) = self.lat.eval(self.s);
        let (dx, dy) = (
            (1.0 - p.kappa * d) * c - d1 * sn,
            (1.0 - p.kappa * d) * sn + d1 * c,
        );
        let g = (dx * dx + dy * dy).sqrt().max(1e-9);
        Snap {
            s: self.s,
            v: self.v,
            a: self.a,
            x: p.x - d * sn,
            y: p.y + d * c,
            hx: dx / g,
            hy: dy / g,
            speed: self.v * g,
        }
    }

    pub fn state(&self, snap: &Snap, acc: f64) -> VehicleState {
        VehicleState {
            x: snap.x as f32,
            y: snap.y as f32,
            vx: (snap.speed * snap.hx) as f32,
            vy: (snap.speed * snap.hy) as f32,
            hx: snap.hx as f32,
            hy: snap.hy as f32,
            acc: acc as f32,
            length: self.length as f32,
            width: self.width as f32,
        }
    }

    fn start_lat(&mut self, dd: f64, len: f64) {
        self.lat.start(self.s, dd, len);
    }

    /// The longitudinal acceleration (m/s^2) the tyres have left beside the lateral
    /// acceleration of the current path (friction circle of radius `b_phys`). The lateral term
    /// is v^2 times the curvature of the reference path plus that of the lateral moves under
    /// way, the small-offset approximation of the driven path's curvature.
    fn longitudinal_grip(&self) -> f64 {
        let kappa = self.path.kappa(self.s) + self.lat.curvature(self.s);
        let lat = self.v * self.v * kappa;
        (self.b_phys * self.b_phys - lat * lat).max(0.0).sqrt()
    }

    /// A planned lane change has not started yet, or is still under way (and not abandoned).
    fn lane_change_pending(&self) -> bool {
        self.plans.iter().any(|p| {
            !p.aborted
                && match p.started {
                    None => true,
                    Some((_, _, s_end)) => self.s < s_end,
                }
        })
    }
}

/// The partner vehicle as a leader in my corridor: (bumper gap, its speed along my heading).
fn corridor_leader(me: &Agent, ms: &Snap, partner: &Agent, os: &Snap) -> Option<(f64, f64)> {
    let (dx, dy) = (os.x - ms.x, os.y - ms.y);
    let long = dx * ms.hx + dy * ms.hy;
    if long <= 0.0 || long > me.driver.sight {
        return None;
    }
    let (ovx, ovy) = (os.speed * os.hx, os.speed * os.hy);
    let v_along = ovx * ms.hx + ovy * ms.hy;
    let cosr = (os.hx * ms.hx + os.hy * ms.hy).abs();
    let sinr = (os.hx * ms.hy - os.hy * ms.hx).abs();
    let half_long = 0.5 * (partner.length * cosr + partner.width * sinr);
    let half_lat = 0.5 * (partner.length * sinr + partner.width * cosr);
    let lat_now = ms.hx * dy - ms.hy * dx;
    let v_lat = ms.hx * ovy - ms.hy * ovx;
    let lat_ahead = lat_now + v_lat * me.driver.anticipation;
    let lat = if lat_now.signum() != lat_ahead.signum() {
        0.0
    } else {
        lat_now.abs().min(lat_ahead.abs())
    };
    if lat > 0.5 * me.width + half_lat + me.driver.margin {
        return None;
    }
    Some((long - 0.5 * me.length - half_long, v_along))
}

/// The two-vehicle simulation state with its perception history.
pub(crate) struct World {
    pub agents: [Agent; 2],
    pub t: f64,
    history: Vec<[Snap; 2]>,
}

impl World {
    pub fn new(agents: [Agent; 2]) -> Self {
        let first = [agents[0].snap(), agents[1].snap()];
        Self {
            agents,
            t: 0.0,
            history: vec![first],
        }
    }

    /// Snapshots as they were `tau` seconds ago (the first one before the start).
    fn perceived(&self, tau: f64) -> [Snap; 2] {
        let lag = (tau / DT).round() as usize;
        let k = self.history.len().saturating_sub(1 + lag);
        self.history[k]
    }

    /// The acceleration driver `i` asks for, from what it perceives.
    fn command(&mut self, i: usize) -> f64 {
        let t = self.t;
        let j = 1 - i;
        let tau = self.agents[i].driver.tau;
        let p = self.perceived(tau);
        let (ms, os) = (p[i], p[j]);
        let me = &self.agents[i];
        let partner = &self.agents[j];
        let drv = &me.driver;
        let mut a = match &me.script {
            Some(sc) => sc.accel(t, self.agents[i].v),
            None => drv.free(ms.v),
        };
        if !drv.reactive {
            return a;
        }
        if t < drv.hold_until {
            return -drv.b_comf;
        }
        if !drv.attentive(t - tau) {
            return me.held_cmd;
        }
        let mut threat = 0.0_f64;
        let mut seen_ttc = f64::INFINITY;
        if let Some((gap, v_lead)) = corridor_leader(me, &ms, partner, &os) {
            if ms.v > v_lead {
                seen_ttc = gap / (ms.v - v_lead);
            }
            let passing =
                drv.pass_intent.is_some_and(|alarm| seen_ttc > alarm) && me.lane_change_pending();
            if !passing {
                let ai = drv.follow(ms.v, v_lead, os.a, gap);
                threat = threat.max(-ai);
                a = a.min(ai);
            }
        }
        let mut stop_at = None;
        if let Some(c) = me.conflict {
            let me_mut = &mut self.agents[i];
            stop_at = conflict_stop(&mut me_mut.crossing, &me_mut.driver, &c, &ms, &os);
        }
        let me = &self.agents[i];
        let drv = &me.driver;
        if let Some(s_stop) = stop_at {
            // Braking to a stop line: the constant deceleration that stops there, applied once
            // it reaches 60 % of the comfortable level (drivers do not creep up with IDM here).
            let dist = s_stop - ms.s;
            let need = ms.v * ms.v / (2.0 * (dist - 0.5).max(0.1));
            if need >= 0.6 * drv.b_comf || dist < 3.0 {
                a = a.min(-need);
            } else if need >= 0.3 * drv.b_comf {
                a = a.min(0.0);
            }
            if matches!(me.conflict.map(|c| c.role), Some(Role::Priority { .. })) {
                threat = threat.max(need);
            }
        }
        if let Some((dist, radius)) = me.path.arc_ahead(ms.s, 150.0) {
            let vc = (drv.a_lat_curve * radius).sqrt();
            if ms.v > vc {
                let need = if dist <= 0.0 {
                    (vc - ms.v) / 1.0
                } else {
                    (vc * vc - ms.v * ms.v) / (2.0 * dist)
                };
                if -need >= 0.5 * drv.b_comf || dist <= 0.0 {
                    a = a.min(need);
                } else if -need >= 0.25 * drv.b_comf {
                    // Close enough to the curve to stop accelerating towards it.
                    a = a.min(0.0);
                }
            }
        }
        if let Some(sw) = drv.swerve {
            if !me.swerved && threat >= sw.trigger {
                let agent = &mut self.agents[i];
                let len = lateral_len(agent.v, sw.dd, sw.alat, &agent.handling);
                agent.start_lat(sw.dir * sw.dd, len);
                agent.swerved = true;
                agent.plans.iter_mut().for_each(|p| p.aborted = true);
            }
        }
        self.agents[i].held_cmd = a;
        self.agents[i].seen_ttc = seen_ttc;
        a
    }

    /// Advances one sub-step.
    pub fn step(&mut self) {
        let cmds = [self.command(0), self.command(1)];
        let t = self.t;
        for (agent, cmd) in self.agents.iter_mut().zip(cmds) {
            // Planned lateral moves (lane changes, drifts, aborts).
            for k in 0..agent.plans.len() {
                let plan = agent.plans[k];
                if plan.aborted {
                    continue;
                }
                match plan.started {
                    None => {
                        let go = match plan.trigger {
                            Trigger::Time(t0) => t >= t0,
                            Trigger::Ttc(ttc) => agent.seen_ttc <= ttc,
                        };
                        if go {
                            let before = agent.lat.target();
                            // The drawn duration, stretched where the vehicle cannot move
                            // that far that fast (its lateral limit or turning circle).
                            let len = (agent.v.max(2.0) * plan.duration).max(5.0).max(lateral_len(
                                agent.v,
                                plan.dd,
                                agent.handling.lat_max,
                                &agent.handling,
                            ));
                            agent.start_lat(plan.dd, len);
                            agent.plans[k].started = Some((t, before, agent.s + len));
                        }
                    }
                    Some((t0, before, s_end)) => {
                        if let Some(ta) = plan.abort_after {
                            if t >= t0 + ta && agent.s < s_end {
                                // Steer back to where the manoeuvre started.
                                let back = before - agent.lat.target();
                                let len = lateral_len(agent.v.max(2.0), back, 3.0, &agent.handling);
                                agent.start_lat(back, len);
                                agent.plans[k].aborted = true;
                            }
                        }
                    }
                }
            }
            let grip = agent.longitudinal_grip();
            let cmd = cmd.clamp(
                -agent.driver.b_max.min(agent.b_phys).min(grip),
                agent
                    .a_phys
                    .min(agent.driver.a_max.max(0.5) * 2.0)
                    .min(grip),
            );
            let dj = agent.driver.jerk * DT;
            // The tyres cap what the brake or engine delivers at once, jerk limit or not.
            agent.a = (agent.a + (cmd - agent.a).clamp(-dj, dj)).clamp(-grip, grip);
            let v_new = agent.v + agent.a * DT;
            if v_new <= 0.0 {
                // Standing: no reversing.
                let dt0 = if agent.a < 0.0 {
                    agent.v / -agent.a
                } else {
                    0.0
                };
                agent.s += 0.5 * agent.v * dt0;
                agent.v = 0.0;
                if agent.a < 0.0 {
                    agent.a = 0.0;
                }
            } else {
                agent.s += 0.5 * (agent.v + v_new) * DT;
                agent.v = v_new;
            }
        }
        self.t += DT;
        let snaps = [self.agents[0].snap(), self.agents[1].snap()];
        self.history.push(snaps);
    }

    /// The current snapshots of both vehicles.
    pub fn snaps(&self) -> [Snap; 2] {
        self.history[self.history.len() - 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAR: Handling = Handling {
        lat_max: 9.0,
        r_min: 5.0,
    };

    #[test]
    fn reaction_delay_postpones_braking() {
        // A follower 30 m behind a standing car at 15 m/s: with tau = 1.5 s the first braking
        // comes 1.5 s later than with an instant driver.
        let first_brake = |tau: f64| {
            let mut d = Driver {
                v0: 15.0,
                headway: 1.5,
                s0: 2.0,
                a_max: 1.0,
                b_comf: 1.5,
                tau,
                b_max: 8.0,
                jerk: 1000.0,
                distraction: Vec::new(),
                margin: 0.3,
                anticipation: 0.0,
                a_lat_curve: 2.0,
                swerve: None,
                hold_until: 0.0,
                reactive: true,
                sight: 200.0,
                law: FollowLaw::Idm,
                pass_intent: None,
            };
            let f = Agent::new(
                Path::line(0.0, 0.0, 0.0),
                0.0,
                15.0,
                (4.5, 1.8),
                (9.0, 3.0),
                CAR,
                d.clone(),
            );
            d.reactive = false;
            let mut l = Agent::new(
                Path::line(0.0, 0.0, 0.0),
                34.5,
                0.0,
                (4.5, 1.8),
                (9.0, 3.0),
                CAR,
                d,
            );
            l.script = Some(Script { pieces: vec![] });
            // The leader appears at t = 0 only: before that the follower saw an empty road.
            let mut w = World::new([f, l]);
            w.history[0][1].x = 1e6;
            let mut t = 0.0;
            while w.agents[0].a > -1.0 && t < 5.0 {
                w.step();
                t += DT;
            }
            t
        };
        let (t0, t1) = (first_brake(0.0), first_brake(1.5));
        assert!(t0 < 0.1, "{t0}");
        assert!((t1 - t0 - 1.5).abs() < 0.05, "{t0} {t1}");
    }
}
