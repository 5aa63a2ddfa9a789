//! The driver model: what each vehicle wants to do (IDM with reaction delay and attention,
//! scripts, swerves, planned lane changes), and the kinematic snapshot it perceives.
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
    pub(super) fn accel(&self, t: f64, v: f64) -> f64 {
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
    /// Extra lateral margin (m) of the corridor in which the partner vehicle counts as ahead.
    pub margin: f64,
    /// Look-ahead (s) used to anticipate a vehicle moving into the corridor.
    pub anticipation: f64,
    /// Comfortable lateral acceleration in curves (m/s^2).
    pub a_lat_curve: f64,
    pub swerve: Option<Swerve>,
    /// The driver keeps the vehicle standing until this time (s), e.g. waiting at a stop line.
    pub hold_until: f64,
    /// False for scripted vehicles that do not react to the partner vehicle.
    pub reactive: bool,
    /// How far ahead (m) the driver takes the partner into account as a leader.
    pub sight: f64,
    /// The car-following law used behind a leader.
    pub law: FollowLaw,
    /// Passing intent: while a planned lane change is pending or under way, a leader in the lane
    /// is not braked for as long as its time to contact stays above this (s); below it the driver
    /// gives up on passing and follows the law (a late or aborted lane change becomes late braking).
    pub pass_intent: Option<f64>,
}

/// Car-following law behind a leader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FollowLaw {
    /// The intelligent driver model.
    Idm,
    /// Treiber and Kesting's ACC model ("Traffic Flow Dynamics", 2013, sec. 11.3.7): IDM blended
    /// with the constant-acceleration heuristic (coolness 0.99), which does not over-brake when a
    /// fast approach to slower traffic begins far ahead (motorway speed differences of 10-25 m/s).
    Acc,
}

impl Driver {
    pub(super) fn attentive(&self, t: f64) -> bool {
        !self.distraction.iter().any(|&(a, b)| t >= a && t < b)
    }

    pub(super) fn idm(&self, v: f64, v_lead: f64, gap: f64) -> f64 {
        let dv = v - v_lead;
        let s_star = self.s0
            + (v * self.headway + v * dv / (2.0 * (self.a_max * self.b_comf).sqrt())).max(0.0);
        self.free(v) - self.a_max * (s_star / gap.max(0.1)).powi(2)
    }

    /// The following law's acceleration behind a leader at `gap` with speed `v_lead` and
    /// acceleration `a_lead`.
    pub(super) fn follow(&self, v: f64, v_lead: f64, a_lead: f64, gap: f64) -> f64 {
        let a_idm = self.idm(v, v_lead, gap);
        match self.law {
            FollowLaw::Idm => a_idm,
            FollowLaw::Acc => {
                const COOLNESS: f64 = 0.99;
                let s = gap.max(0.1);
                let a_l = a_lead.min(self.a_max);
                let dv = v - v_lead;
                let a_cah = if v_lead * dv <= -2.0 * s * a_l {
                    v * v * a_l / (v_lead * v_lead - 2.0 * s * a_l).max(1e-6)
                } else {
                    a_l - dv.max(0.0).powi(2) / (2.0 * s)
                };
                if a_idm >= a_cah {
                    a_idm
                } else {
                    (1.0 - COOLNESS) * a_idm
                        + COOLNESS * (a_cah + self.b_comf * ((a_idm - a_cah) / self.b_comf).tanh())
                }
            }
        }
    }

    pub(super) fn free(&self, v: f64) -> f64 {
        self.a_max * (1.0 - (v / self.v0.max(0.1)).powi(4))
    }
}

/// When a planned lateral move starts.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Trigger {
    Time(f64),
    /// When the perceived time to contact with a leader in the lane falls to this (s): a driver
    /// who starts to pass when the slower vehicle ahead gets that close.
    Ttc(f64),
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
