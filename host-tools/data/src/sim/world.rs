//! The two-vehicle world: reference paths, lateral manoeuvres, driver model and integration.
//!
//! Each vehicle moves along a reference path (straight lines and circular arcs) with a lateral
//! offset `d(s)` that is a smooth (quintic) function of the distance travelled, so heading always
//! equals the direction of motion and a vehicle never moves sideways while standing. Longitudinal
//! motion is the driver's commanded acceleration (IDM with reaction delay, or a script), applied
//! through a jerk limit and the vehicle's physical acceleration/braking limits.
use scorer_core::VehicleState;

/// Integration step (s): 5 sub-steps per 10 Hz frame.
pub(crate) const DT: f64 = 0.02;
pub(crate) const SUBSTEPS: usize = 5;
pub(crate) const FRAME_DT: f64 = DT * SUBSTEPS as f64;

/// One piece of a reference path.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Seg {
    Line(f64),
    /// Circular arc of length `len` and signed curvature `kappa` (positive turns left).
    Arc {
        len: f64,
        kappa: f64,
    },
}

/// A reference path: a start pose and segments; extended straight before and after.
#[derive(Clone, Debug)]
pub(crate) struct Path {
    /// (s at segment start, x, y, psi) for each segment, plus the end pose.
    knots: Vec<(f64, f64, f64, f64)>,
    segs: Vec<Seg>,
}

/// Position, heading angle and curvature of a path point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pose {
    pub x: f64,
    pub y: f64,
    pub psi: f64,
    pub kappa: f64,
}

impl Path {
    pub fn new(x: f64, y: f64, psi: f64, segs: Vec<Seg>) -> Self {
        let mut knots = vec![(0.0, x, y, psi)];
        for seg in &segs {
            let &(s0, x0, y0, p0) = knots.last().unwrap_or(&(0.0, x, y, psi));
            let (len, end) = match *seg {
                Seg::Line(len) => (len, line_pose(x0, y0, p0, len)),
                Seg::Arc { len, kappa } => (len, arc_pose(x0, y0, p0, kappa, len)),
            };
            knots.push((s0 + len, end.x, end.y, end.psi));
        }
        Self { knots, segs }
    }

    /// An endless straight line through `(x, y)` with heading `psi`.
    pub fn line(x: f64, y: f64, psi: f64) -> Self {
        Self::new(x, y, psi, Vec::new())
    }

    pub fn pose(&self, s: f64) -> Pose {
        let &(_, x0, y0, p0) = &self.knots[0];
        if s <= 0.0 {
            return line_pose(x0, y0, p0, s);
        }
        for (i, seg) in self.segs.iter().enumerate() {
            let (k0, kx, ky, kp) = self.knots[i];
            let (len, kappa) = match *seg {
                Seg::Line(len) => (len, 0.0),
                Seg::Arc { len, kappa } => (len, kappa),
            };
            if s < k0 + len {
                return if kappa == 0.0 {
                    line_pose(kx, ky, kp, s - k0)
                } else {
                    arc_pose(kx, ky, kp, kappa, s - k0)
                };
            }
        }
        let &(k0, kx, ky, kp) = self.knots.last().unwrap_or(&self.knots[0]);
        line_pose(kx, ky, kp, s - k0)
    }

    /// Distance from `s` to the next arc (0 inside one) and its radius, looking `range` m ahead.
    pub fn arc_ahead(&self, s: f64, range: f64) -> Option<(f64, f64)> {
        for (i, seg) in self.segs.iter().enumerate() {
            if let Seg::Arc { len, kappa } = *seg {
                let k0 = self.knots[i].0;
                if s < k0 + len && k0 - s <= range {
                    return Some(((k0 - s).max(0.0), 1.0 / kappa.abs()));
                }
            }
        }
        None
    }
}

fn line_pose(x: f64, y: f64, psi: f64, u: f64) -> Pose {
    Pose {
        x: x + u * psi.cos(),
        y: y + u * psi.sin(),
        psi,
        kappa: 0.0,
    }
}

fn arc_pose(x: f64, y: f64, psi: f64, kappa: f64, u: f64) -> Pose {
    let p1 = psi + kappa * u;
    Pose {
        x: x + (p1.sin() - psi.sin()) / kappa,
        y: y - (p1.cos() - psi.cos()) / kappa,
        psi: p1,
        kappa,
    }
}

/// A smooth lateral move from offset `d0` to `d1` over path distance `[s0, s0 + len]`
/// (quintic with zero slope and curvature at both ends).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LatMove {
    pub s0: f64,
    pub len: f64,
    pub d0: f64,
    pub d1: f64,
}

impl LatMove {
    /// Offset and its slope d'(s).
    pub fn eval(&self, s: f64) -> (f64, f64) {
        let u = ((s - self.s0) / self.len).clamp(0.0, 1.0);
        let q = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
        let dq = 30.0 * u * u * (1.0 - u) * (1.0 - u);
        let dd = self.d1 - self.d0;
        (self.d0 + dd * q, dd * dq / self.len)
    }
}

/// The lateral offset of a vehicle: a sum of smooth moves, so a move started during another
/// (a swerve during a lane change, an abort) keeps offset, heading and curvature continuous.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lateral {
    moves: Vec<LatMove>,
}

impl Lateral {
    /// Offset and its slope d'(s).
    pub fn eval(&self, s: f64) -> (f64, f64) {
        self.moves.iter().fold((0.0, 0.0), |(d, d1), m| {
            let (a, b) = m.eval(s);
            (d + a, d1 + b)
        })
    }
    /// The offset once every move has finished.
    pub fn target(&self) -> f64 {
        self.moves.iter().map(|m| m.d1).sum()
    }
    /// Adds a move of `dd` m over `[s, s + len]`.
    pub fn start(&mut self, s: f64, dd: f64, len: f64) {
        self.moves.push(LatMove {
            s0: s,
            len,
            d0: 0.0,
            d1: dd,
        });
    }
}

/// Path distance needed for a lateral move of `dd` m with peak lateral acceleration `alat` at
/// speed `v` (quintic profile: peak d'' = 5.77 dd / len^2).
pub(crate) fn lateral_len(v: f64, dd: f64, alat: f64) -> f64 {
    (v * (5.77 * dd.abs() / alat).sqrt()).max(3.0)
}

/// The kinematic state of one vehicle at one instant (local scenario frame).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Snap {
    pub s: f64,
    pub v: f64,
    pub a: f64,
    pub x: f64,
    pub y: f64,
    pub hx: f64,
    pub hy: f64,
    pub speed: f64,
}

/// Piecewise scripted longitudinal behaviour (lead vehicles, stopped vehicles).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Piece {
    /// Constant acceleration `a` while the speed stays in `[v_lo, v_hi]`.
    Accel { a: f64, v_lo: f64, v_hi: f64 },
    /// Speed fluctuation: acceleration `amp * sin(2 pi t / period)`.
    Sine { amp: f64, period: f64 },
}

#[derive(Clone, Debug)]
pub(crate) struct Script {
    /// (start time, piece), sorted by start time.
    pub pieces: Vec<(f64, Piece)>,
}

impl Script {
    fn accel(&self, t: f64, v: f64) -> f64 {
        let Some(&(_, p)) = self.pieces.iter().rev().find(|(t0, _)| *t0 <= t) else {
            return 0.0;
        };
        match p {
            Piece::Accel { a, v_lo, v_hi } => {
                if (a < 0.0 && v <= v_lo) || (a > 0.0 && v >= v_hi) {
                    0.0
                } else {
                    a
                }
            }
            Piece::Sine { amp, period } => amp * (std::f64::consts::TAU * t / period).sin(),
        }
    }
}

/// An evasive swerve the driver performs once when braking demand exceeds `trigger`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Swerve {
    /// +1 to the left of the path, -1 to the right.
    pub dir: f64,
    pub dd: f64,
    pub alat: f64,
    /// Deceleration demand (m/s^2, positive) that triggers the swerve.
    pub trigger: f64,
}

/// The driver: IDM parameters, reaction delay, attention and evasive habits.
#[derive(Clone, Debug)]
pub(crate) struct Driver {
    pub v0: f64,
    pub headway: f64,
    pub s0: f64,
    pub a_max: f64,
    pub b_comf: f64,
    /// Perception-reaction delay (s): decisions use the world as it was `tau` ago.
    pub tau: f64,
    /// Hardest braking this driver applies (m/s^2), further capped by the vehicle.
    pub b_max: f64,
    /// Jerk limit of the longitudinal actuation (m/s^3).
    pub jerk: f64,
    /// Intervals `[a, b)` of inattention: what happens then is not perceived.
    pub distraction: Vec<(f64, f64)>,
    /// Extra lateral margin (m) of the corridor in which the other vehicle counts as ahead.
    pub margin: f64,
    /// Look-ahead (s) used to anticipate a vehicle moving into the corridor.
    pub anticipation: f64,
    /// Comfortable lateral acceleration in curves (m/s^2).
    pub a_lat_curve: f64,
    pub swerve: Option<Swerve>,
    /// The driver keeps the vehicle standing until this time (s), e.g. waiting at a stop line.
    pub hold_until: f64,
    /// False for scripted vehicles that do not react to the other vehicle.
    pub reactive: bool,
}

impl Driver {
    fn attentive(&self, t: f64) -> bool {
        !self.distraction.iter().any(|&(a, b)| t >= a && t < b)
    }

    fn idm(&self, v: f64, v_lead: f64, gap: f64) -> f64 {
        let dv = v - v_lead;
        let s_star = self.s0
            + (v * self.headway + v * dv / (2.0 * (self.a_max * self.b_comf).sqrt())).max(0.0);
        self.free(v) - self.a_max * (s_star / gap.max(0.1)).powi(2)
    }

    fn free(&self, v: f64) -> f64 {
        self.a_max * (1.0 - (v / self.v0.max(0.1)).powi(4))
    }
}

/// Role of a vehicle at a crossing conflict zone.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Role {
    /// Gives way: goes when the other's (misjudged) arrival leaves at least `margin` s after it
    /// would clear the zone; `blind` drivers never look.
    Yield {
        margin: f64,
        misjudge: f64,
        blind: bool,
    },
    /// Has right of way; brakes for a vehicle that is visibly not giving way.
    Priority { margin: f64 },
}

/// A crossing conflict zone in path coordinates of both vehicles (centre positions at which the
/// boxes can touch, widened by half lengths).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Conflict {
    pub me_in: f64,
    pub me_out: f64,
    pub other_in: f64,
    pub other_out: f64,
    pub role: Role,
}

/// When a planned lateral move starts.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Trigger {
    Time(f64),
}

/// A planned lane change (or drift): lateral move of `dd` m lasting `duration` s at the current
/// speed; optionally abandoned `abort_after` s after it began (the driver noticed the conflict).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LatPlan {
    pub trigger: Trigger,
    pub dd: f64,
    pub duration: f64,
    pub abort_after: Option<f64>,
    /// (start time, lateral target before the move, path position where it ends).
    pub started: Option<(f64, f64, f64)>,
    pub aborted: bool,
}

impl LatPlan {
    pub fn new(trigger: Trigger, dd: f64, duration: f64) -> Self {
        Self {
            trigger,
            dd,
            duration,
            abort_after: None,
            started: None,
            aborted: false,
        }
    }
}

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
    pub driver: Driver,
    pub script: Option<Script>,
    pub plans: Vec<LatPlan>,
    pub conflict: Option<Conflict>,
    held_cmd: f64,
    swerved: bool,
    committed: bool,
    released: bool,
}

impl Agent {
    pub fn new(
        path: Path,
        s: f64,
        v: f64,
        dims: (f64, f64),
        limits: (f64, f64),
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
            driver,
            script: None,
            plans: Vec::new(),
            conflict: None,
            held_cmd: 0.0,
            swerved: false,
            committed: false,
            released: false,
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
}

/// The other vehicle as a leader in my corridor: (bumper gap, its speed along my heading).
fn corridor_leader(me: &Agent, ms: &Snap, other: &Agent, os: &Snap) -> Option<(f64, f64)> {
    let (dx, dy) = (os.x - ms.x, os.y - ms.y);
    let long = dx * ms.hx + dy * ms.hy;
    if long <= 0.0 || long > 200.0 {
        return None;
    }
    let (ovx, ovy) = (os.speed * os.hx, os.speed * os.hy);
    let v_along = ovx * ms.hx + ovy * ms.hy;
    let cosr = (os.hx * ms.hx + os.hy * ms.hy).abs();
    let sinr = (os.hx * ms.hy - os.hy * ms.hx).abs();
    let half_long = 0.5 * (other.length * cosr + other.width * sinr);
    let half_lat = 0.5 * (other.length * sinr + other.width * cosr);
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

/// Time to cover `dist` from speed `v`, accelerating at `a` up to `vmax`.
fn travel_time(dist: f64, v: f64, a: f64, vmax: f64) -> f64 {
    if dist <= 0.0 {
        return 0.0;
    }
    let vmax = vmax.max(v).max(0.5);
    let t1 = (vmax - v) / a.max(0.1);
    let d1 = 0.5 * (v + vmax) * t1;
    if dist <= d1 {
        (-v + (v * v + 2.0 * a * dist).sqrt()) / a.max(0.1)
    } else {
        t1 + (dist - d1) / vmax
    }
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
        let other = &self.agents[j];
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
        if let Some((gap, v_lead)) = corridor_leader(me, &ms, other, &os) {
            let ai = drv.idm(ms.v, v_lead, gap);
            threat = threat.max(-ai);
            a = a.min(ai);
        }
        let mut stop_at = None;
        if let Some(c) = me.conflict {
            let me_mut = &mut self.agents[i];
            stop_at = conflict_stop(me_mut, &c, &ms, &os);
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
                let len = lateral_len(self.agents[i].v, sw.dd, sw.alat);
                let agent = &mut self.agents[i];
                agent.start_lat(sw.dir * sw.dd, len);
                agent.swerved = true;
                agent.plans.iter_mut().for_each(|p| p.aborted = true);
            }
        }
        self.agents[i].held_cmd = a;
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
                        };
                        if go {
                            let before = agent.lat.target();
                            let len = (agent.v.max(2.0) * plan.duration).max(5.0);
                            agent.start_lat(plan.dd, len);
                            agent.plans[k].started = Some((t, before, agent.s + len));
                        }
                    }
                    Some((t0, before, s_end)) => {
                        if let Some(ta) = plan.abort_after {
                            if t >= t0 + ta && agent.s < s_end {
                                // Steer back to where the manoeuvre started.
                                let back = before - agent.lat.target();
                                let len = lateral_len(agent.v.max(2.0), back, 3.0);
                                agent.start_lat(back, len);
                                agent.plans[k].aborted = true;
                            }
                        }
                    }
                }
            }
            let cmd = cmd.clamp(
                -agent.driver.b_max.min(agent.b_phys),
                agent.a_phys.min(agent.driver.a_max.max(0.5) * 2.0),
            );
            let dj = agent.driver.jerk * DT;
            agent.a += (cmd - agent.a).clamp(-dj, dj);
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

/// Where the driver stops for a crossing conflict, if it does (yield and priority logic).
fn conflict_stop(me: &mut Agent, c: &Conflict, ms: &Snap, os: &Snap) -> Option<f64> {
    match c.role {
        Role::Yield {
            margin,
            misjudge,
            blind,
        } => {
            if me.committed || blind {
                return None;
            }
            if ms.s >= c.me_in - 0.5 {
                me.committed = true;
                return None;
            }
            let dist = c.me_in - ms.s;
            let decide_at = ms.v * ms.v / (2.0 * 0.6 * me.driver.b_comf) + 5.0;
            if dist > decide_at {
                return None;
            }
            let gone = os.s > c.other_out;
            let inside = os.s >= c.other_in && !gone;
            let accept = gone
                || (!inside && {
                    let t_o = (c.other_in - os.s) / (os.v * misjudge).max(0.1);
                    let t_c = travel_time(c.me_out - ms.s, ms.v, me.driver.a_max, me.driver.v0);
                    t_o - t_c >= margin
                });
            if accept {
                me.committed = true;
                None
            } else {
                // Stop line 2.5 m before the zone, clear of the other's lane.
                Some(c.me_in - 2.5)
            }
        }
        Role::Priority { margin } => {
            if me.released || os.s > c.other_out {
                me.released = true;
                return None;
            }
            if ms.s >= c.me_in - 0.5 {
                return None;
            }
            let inside = os.s >= c.other_in;
            let d_o = c.other_in - os.s;
            // Right of way: the other is assumed to give way until it is close to the zone and
            // visibly not stopping (not braking, or needing more than 3.5 m/s^2 to stop).
            let close = d_o < os.v * os.v / (2.0 * 3.0) + 5.0;
            let need = os.v * os.v / (2.0 * (d_o - 1.0).max(0.5));
            let stopping = os.v < 0.5 || (os.a < -0.5 && need < 3.5);
            if !inside && (!close || stopping) {
                return None;
            }
            let v = ms.v.max(0.5);
            let t_me_in = (c.me_in - ms.s) / v;
            let t_me_out = (c.me_out - ms.s) / v;
            let ov = os.v.max(0.1);
            let t_o_in = if inside { 0.0 } else { d_o / ov };
            let t_o_out = (c.other_out - os.s) / ov;
            let clash = t_o_in < t_me_out + margin && t_o_out > t_me_in - margin;
            (clash && t_me_in < 8.0).then_some(c.me_in - 1.0)
        }
    }
}

/// The conflict zone of two paths, searched over `a_range` x `b_range` (path distances) with a
/// 0.5 m step: centre positions where the two vehicles' paths come within half their widths
/// (+0.3 m), widened by half each vehicle's length. `None` when the paths never meet there.
pub(crate) fn conflict_zone(
    a: (&Path, f64, f64),
    b: (&Path, f64, f64),
    a_range: (f64, f64),
    b_range: (f64, f64),
) -> Option<(f64, f64, f64, f64)> {
    let r = 0.5 * (a.2 + b.2) + 0.3;
    let step = 0.5;
    let bs: Vec<(f64, Pose)> = {
        let mut v = Vec::new();
        let mut s = b_range.0;
        while s <= b_range.1 {
            v.push((s, b.0.pose(s)));
            s += step;
        }
        v
    };
    let (mut a_lo, mut a_hi, mut b_lo, mut b_hi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let mut sa = a_range.0;
    while sa <= a_range.1 {
        let pa = a.0.pose(sa);
        for (sb, pb) in &bs {
            let (dx, dy) = (pa.x - pb.x, pa.y - pb.y);
            if dx * dx + dy * dy < r * r {
                a_lo = a_lo.min(sa);
                a_hi = a_hi.max(sa);
                b_lo = b_lo.min(*sb);
                b_hi = b_hi.max(*sb);
            }
        }
        sa += step;
    }
    (a_lo <= a_hi).then_some((
        a_lo - 0.5 * a.1 - 0.5,
        a_hi + 0.5 * a.1 + 0.5,
        b_lo - 0.5 * b.1 - 0.5,
        b_hi + 0.5 * b.1 + 0.5,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arcs_join_lines_continuously() {
        // Quarter left turn of radius 10 after 5 m, then straight.
        let p = Path::new(
            1.0,
            2.0,
            0.0,
            vec![
                Seg::Line(5.0),
                Seg::Arc {
                    len: 10.0 * std::f64::consts::FRAC_PI_2,
                    kappa: 0.1,
                },
                Seg::Line(20.0),
            ],
        );
        let end = p.pose(5.0 + 10.0 * std::f64::consts::FRAC_PI_2);
        assert!(
            (end.x - 16.0).abs() < 1e-9 && (end.y - 12.0).abs() < 1e-9,
            "{end:?}"
        );
        assert!((end.psi - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Unit speed along the path everywhere, including across joints and the extensions.
        let mut s = -3.0;
        while s < 45.0 {
            let (a, b) = (p.pose(s), p.pose(s + 1e-4));
            let step = (b.x - a.x).hypot(b.y - a.y) / 1e-4;
            assert!((step - 1.0).abs() < 1e-3, "s = {s}: {step}");
            s += 0.37;
        }
        assert_eq!(
            p.arc_ahead(0.0, 10.0).map(|(d, r)| (d, r.round())),
            Some((5.0, 10.0))
        );
        assert!(p.arc_ahead(0.0, 4.0).is_none());
        assert!(p.arc_ahead(30.0, 100.0).is_none());
    }

    #[test]
    fn lateral_moves_are_smooth_and_superpose() {
        let mut lat = Lateral::default();
        lat.start(10.0, 3.5, 50.0);
        assert_eq!(lat.eval(10.0), (0.0, 0.0));
        let (d, d1) = lat.eval(35.0);
        assert!((d - 1.75).abs() < 1e-12 && (d1 - 3.5 * 1.875 / 50.0).abs() < 1e-12);
        assert_eq!(lat.eval(60.0), (3.5, 0.0));
        // A second move started mid-way keeps the slope continuous.
        let before = lat.eval(30.0);
        lat.start(30.0, -3.5, 20.0);
        assert_eq!(lat.eval(30.0), before);
        assert!((lat.target()).abs() < 1e-12);
        assert!(lat.eval(100.0).0.abs() < 1e-12);
        // Peak lateral acceleration of a move matches `lateral_len`.
        let len = lateral_len(20.0, 2.0, 4.0);
        let m = LatMove {
            s0: 0.0,
            len,
            d0: 0.0,
            d1: 2.0,
        };
        let h = 1e-3;
        let peak = (1..1000)
            .map(|i| {
                let s = len * i as f64 / 1000.0;
                ((m.eval(s + h).1 - m.eval(s - h).1) / (2.0 * h) * 400.0).abs()
            })
            .fold(0.0, f64::max);
        assert!((peak - 4.0).abs() < 0.02, "{peak}");
    }

    #[test]
    fn travel_time_accelerates_then_cruises() {
        // From 0 at 2 m/s^2 to 10 m/s: 5 s and 25 m, then 10 m/s.
        assert!((travel_time(25.0, 0.0, 2.0, 10.0) - 5.0).abs() < 1e-9);
        assert!((travel_time(45.0, 0.0, 2.0, 10.0) - 7.0).abs() < 1e-9);
        assert!((travel_time(9.0, 0.0, 2.0, 10.0) - 3.0).abs() < 1e-9);
        assert_eq!(travel_time(-1.0, 5.0, 1.0, 10.0), 0.0);
    }

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
            };
            let f = Agent::new(
                Path::line(0.0, 0.0, 0.0),
                0.0,
                15.0,
                (4.5, 1.8),
                (9.0, 3.0),
                d.clone(),
            );
            d.reactive = false;
            let mut l = Agent::new(
                Path::line(0.0, 0.0, 0.0),
                34.5,
                0.0,
                (4.5, 1.8),
                (9.0, 3.0),
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
