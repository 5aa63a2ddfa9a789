//! Received inputs kept between frames: time-stamped values, each track's state and own motion.
use crate::map::PARTNER_FIELDS;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Track ids are small integers chosen by a sensor, not by an attacker: a multiplicative hash is
/// enough and several times cheaper than SipHash on the per-frame path.
#[derive(Default)]
pub(super) struct TrackIdHasher(u64);

impl Hasher for TrackIdHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(*b)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.0 = (u64::from(v) ^ 0x5555_5555).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

pub(super) type TrackMap<V> = HashMap<u32, V, BuildHasherDefault<TrackIdHasher>>;

/// A received input value and the time of the frame it came in.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Stamped {
    pub value: f64,
    pub t_us: u64,
}

impl Stamped {
    /// The value if it is at most `stale_us` old at `t_us`.
    pub fn fresh(v: Option<Self>, t_us: u64, stale_us: u64) -> Option<f64> {
        v.filter(|s| t_us.saturating_sub(s.t_us) <= stale_us)
            .map(|s| s.value)
    }
}

/// A track's own motion: the position at the start of the current window and the velocity
/// measured over the last complete window (ego frame, relative to the ego).
#[derive(Clone, Copy, Debug)]
pub(super) struct Motion {
    anchor_us: u64,
    anchor: (f64, f64),
    velocity: Option<(f64, f64)>,
}

/// What the engine holds of one track between frames.
#[derive(Clone, Debug, Default)]
pub(super) struct PartnerSlots {
    /// The last value of each object field, by [`crate::map::PartnerField`].
    pub values: [Option<Stamped>; PARTNER_FIELDS],
    pub last_trigger_us: Option<u64>,
    pub last_heading: Option<(f32, f32)>,
    pub last_seen_us: u64,
    pub motion: Option<Motion>,
    /// A missing input of this track has been reported (once, until it arrives).
    pub waiting_reported: bool,
    /// The track's id does not fit the warning message and this has been reported.
    pub unsent_reported: bool,
}

/// Advances a track's motion window with the position `p` at `t_us`; returns the velocity over
/// the last complete window. A gap longer than the window plus the staleness limit restarts it.
///
/// The positions are in the ego frame, which turns with the ego: with its `yaw_rate` (rad/s,
/// counter-clockwise) known, both positions are first turned into the axes of the window's middle
/// (by `-+yaw_rate * dt / 2`), so a point fixed on the ground does not seem to sweep round the
/// ego; the velocity is then relative to the ego in its own axes, as the scorer expects.
pub(super) fn update_motion(
    motion: &mut Option<Motion>,
    t_us: u64,
    p: (f64, f64),
    window_us: u64,
    stale_us: u64,
    yaw_rate: Option<f64>,
) -> Option<(f64, f64)> {
    let restart = Motion {
        anchor_us: t_us,
        anchor: p,
        velocity: None,
    };
    let m = match motion {
        Some(m) if t_us >= m.anchor_us && t_us - m.anchor_us <= window_us + stale_us => m,
        _ => {
            *motion = Some(restart);
            return None;
        }
    };
    let dt_us = t_us - m.anchor_us;
    if dt_us >= window_us {
        let dt = dt_us as f64 / 1e6;
        let turn = yaw_rate.unwrap_or(0.0) * dt;
        let rotate = |(x, y): (f64, f64), angle: f64| {
            let (c, s) = (libm::cos(angle), libm::sin(angle));
            (c * x - s * y, s * x + c * y)
        };
        // Both ends in the axes of the window's middle: the mean velocity over a steady turn
        // points the way the middle's axes do.
        let a = rotate(m.anchor, -turn / 2.0);
        let b = rotate(p, turn / 2.0);
        m.velocity = Some(((b.0 - a.0) / dt, (b.1 - a.1) / dt));
        m.anchor_us = t_us;
        m.anchor = p;
    }
    m.velocity
}

/// The ego's heading at the start of the current window and the rate measured over the last
/// complete one.
#[derive(Clone, Copy, Debug)]
pub(super) struct HeadingRate {
    anchor_us: u64,
    anchor: f64,
    rate: Option<f64>,
}

/// Advances the heading window with `heading` (rad) at `t_us`; returns the yaw rate (rad/s) over
/// the last complete window (the change wrapped to (-pi, pi], so a heading signal that wraps at
/// 2 pi or at +-pi gives no jump). A gap longer than the window plus the staleness limit restarts it.
pub(super) fn update_heading_rate(
    state: &mut Option<HeadingRate>,
    t_us: u64,
    heading: f64,
    window_us: u64,
    stale_us: u64,
) -> Option<f64> {
    let s = match state {
        Some(s) if t_us >= s.anchor_us && t_us - s.anchor_us <= window_us + stale_us => s,
        _ => {
            *state = Some(HeadingRate {
                anchor_us: t_us,
                anchor: heading,
                rate: None,
            });
            return None;
        }
    };
    let dt_us = t_us - s.anchor_us;
    if dt_us >= window_us {
        let tau = core::f64::consts::TAU;
        let mut change = (heading - s.anchor) % tau;
        if change > core::f64::consts::PI {
            change -= tau;
        } else if change <= -core::f64::consts::PI {
            change += tau;
        }
        s.rate = Some(change / (dt_us as f64 / 1e6));
        s.anchor_us = t_us;
        s.anchor = heading;
    }
    s.rate
}
