//! The random parts every scenario family draws: vehicles, road speeds, drivers, scripts,
//! distraction, and the assignment of the ego to a role.
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::sim::world::{Agent, Driver, FollowLaw, Handling, Path, Piece, Script, Swerve};

/// Vehicle classes and their dimension/performance ranges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VehicleClass {
    Car,
    Van,
    Truck,
    Motorbike,
    /// A stationary roadside object that is not a vehicle (debris, a barrier element, a bin).
    Object,
}

impl VehicleClass {
    pub fn name(self) -> &'static str {
        match self {
            VehicleClass::Car => "car",
            VehicleClass::Van => "van",
            VehicleClass::Truck => "truck",
            VehicleClass::Motorbike => "motorbike",
            VehicleClass::Object => "object",
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

pub(crate) fn u(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

pub(super) fn sign(rng: &mut ChaCha8Rng) -> f64 {
    if rng.random_bool(0.5) {
        1.0
    } else {
        -1.0
    }
}

pub(super) fn vehicle(rng: &mut ChaCha8Rng, ego: bool) -> Vehicle {
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
        VehicleClass::Motorbike | VehicleClass::Object => (
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
pub(super) fn road_speed(rng: &mut ChaCha8Rng) -> f64 {
    let r: f64 = rng.random();
    if r < 0.4 {
        u(rng, 8.0, 16.0)
    } else if r < 0.75 {
        u(rng, 14.0, 22.0)
    } else {
        u(rng, 22.0, 33.0)
    }
}

/// Scripted cruising: no acceleration at any speed.
pub(super) const CRUISE: Piece = Piece::Accel {
    a: 0.0,
    v_lo: 0.0,
    v_hi: f64::MAX,
};

/// A driver whose desired speed is `v` times a factor drawn from `factor`.
pub(super) fn driver(rng: &mut ChaCha8Rng, hazardous: bool, v: f64, factor: (f64, f64)) -> Driver {
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
        sight: 200.0,
        law: FollowLaw::Idm,
        pass_intent: None,
    }
}

/// A vehicle that follows a script and does not react.
pub(super) fn scripted(
    rng: &mut ChaCha8Rng,
    v: f64,
    pieces: Vec<(f64, Piece)>,
) -> (Driver, Script) {
    let mut d = driver(rng, false, v.max(0.1), (1.0, 1.0 + 1e-9));
    d.reactive = false;
    d.swerve = None;
    d.jerk = u(rng, 5.0, 15.0);
    (d, Script { pieces })
}

/// What a vehicle of this class can do sideways with tyres that brake at `b_phys` m/s^2: the
/// same grip laterally (a truck: its rollover threshold, about 4 m/s^2, when lower), and the
/// tightest radius its steering allows (half the kerb-to-kerb turning circle: cars 10-11 m, vans
/// about 12 m, rigid and articulated trucks 16-25 m, motorbikes about 5 m).
pub(super) fn handling(class: VehicleClass, b_phys: f64) -> Handling {
    let (lat_max, r_min) = match class {
        VehicleClass::Car => (b_phys, 5.0),
        VehicleClass::Van => (b_phys, 6.0),
        VehicleClass::Truck => (b_phys.min(4.0), 8.0),
        VehicleClass::Motorbike | VehicleClass::Object => (b_phys, 2.5),
    };
    Handling { lat_max, r_min }
}

/// The radius (m) of a turn or ramp arc that `veh` drives, drawn U(`lo`, `hi`) but never tighter
/// than the class can steer (`Handling::r_min`): the bounds become `max(lo, r_min)` and
/// `max(hi, max(lo, r_min))`. A vehicle whose `r_min` is at most `lo` draws exactly as an
/// unrestricted draw would, and every vehicle consumes the same single draw, so what is drawn
/// after it does not shift.
pub(super) fn arc_radius(rng: &mut ChaCha8Rng, lo: f64, hi: f64, veh: &Vehicle) -> f64 {
    let lo = lo.max(handling(veh.class, veh.limits.0).r_min);
    if hi > lo {
        u(rng, lo, hi)
    } else {
        // The range is empty, the radius is `lo`; the draw is still made, so the stream stays
        // aligned.
        u(rng, 0.0, 1.0);
        lo
    }
}

pub(super) fn agent(path: Path, s: f64, v: f64, veh: &Vehicle, driver: Driver) -> Agent {
    let handling = handling(veh.class, veh.limits.0);
    Agent::new(path, s, v, veh.dims, veh.limits, handling, driver)
}

/// Draws whether the ego takes role A (with probability `p_ego_first`) and returns that flag with
/// the role-A and role-B vehicles: `(ego, partner)` when it does, else `(partner, ego)`.
pub(super) fn roles<'v>(
    rng: &mut ChaCha8Rng,
    p_ego_first: f64,
    ego: &'v Vehicle,
    partner: &'v Vehicle,
) -> (bool, &'v Vehicle, &'v Vehicle) {
    if rng.random_bool(p_ego_first) {
        (true, ego, partner)
    } else {
        (false, partner, ego)
    }
}

pub(super) type Built = (Agent, Agent, f64, bool);

pub(super) fn distraction(
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

/// The driver has been looking away since before the recording began and looks back at `until`
/// (s): nothing seen earlier is acted on, so the first reaction comes `tau` after `until`.
pub(super) fn distracted_until(d: &mut Driver, until: f64) {
    d.distraction.push((f64::NEG_INFINITY, until));
}
