//! The run-end sanity report: warnings when the decoded states look like a map mistake (a unit
//! not converted, a sign flipped, a sensor offset forgotten) rather than like traffic. Each says
//! what looked wrong, by how much, and which map mistake usually causes it. A run that passes is
//! not proven right: `can-bridge decode` and a target of known position are (docs/can-bridge.md).
use crate::engine::{InputFlags, ScoredUpdate};
use std::collections::HashMap;

/// Above this the ego speed is no road vehicle's (m/s; 252 km/h).
pub const EGO_SPEED_MAX: f32 = 70.0;
/// Above this a partner's speed over ground is implausible (m/s; 324 km/h).
pub const PARTNER_SPEED_MAX: f32 = 90.0;
/// Beyond this distance ahead/behind (m) no sensor reports objects (radars: 250-300 m; simulated
/// event logs reach 500 m); a distance in cm ends up here from 10 m on.
pub const FAR_X: f32 = 1000.0;
/// Beyond this distance to the side (m).
pub const FAR_Y: f32 = 200.0;
/// A track inside the ego's box for this long is no crash (a crash ends the drive or the event).
const INSIDE_PERSISTENT_US: u64 = 1_000_000;
/// Tracks whose own motion is followed for the speed-versus-motion check (bounded memory).
const FOLLOWED_TRACKS: usize = 4096;
/// Shortest interval (s) over which a position change is compared with the reported speed.
const MOTION_MIN_DT: f64 = 0.1;
/// Speeds (m/s) below this are too small to tell a sign or a ratio.
const MOTION_MIN_SPEED: f64 = 0.5;

/// A track's last position and time, for its position change.
#[derive(Clone, Copy, Debug)]
struct Followed {
    t_us: u64,
    x: f64,
    y: f64,
    /// The side it was first seen on with |y| > 1 m (1 left, -1 right, 0 not yet).
    side: i8,
    /// Since when it has been inside the ego's box without a break.
    inside_since_us: Option<u64>,
}

/// What the report has seen so far.
#[derive(Debug, Default)]
pub struct Sanity {
    updates: u64,
    ego_fast: u64,
    ego_speed_max: f32,
    partner_fast: u64,
    partner_speed_max: f32,
    overlaps: u64,
    /// The deepest overlap: (x, y, bumpers-touch distance along x).
    deepest_overlap: Option<(f32, f32, f32)>,
    /// Tracks inside the ego's box for at least [`INSIDE_PERSISTENT_US`].
    inside_tracks: u64,
    far: u64,
    farthest: (f32, f32),
    size_default: u64,
    default_size: Option<(f32, f32)>,
    followed: HashMap<u32, Followed>,
    left: u64,
    right: u64,
    lat_compared: u64,
    lat_opposite: u64,
    /// Reported / position-change longitudinal relative speed, for the median ratio.
    long_ratios: Vec<f32>,
}

impl Sanity {
    /// Takes one scored update into account.
    pub fn observe(&mut self, u: &ScoredUpdate) {
        self.updates += 1;
        let (ego, p) = (&u.ego, &u.partner);
        let ego_speed = ego.speed();
        self.ego_speed_max = self.ego_speed_max.max(ego_speed);
        if ego_speed > EGO_SPEED_MAX {
            self.ego_fast += 1;
        }
        let speed = p.speed();
        self.partner_speed_max = self.partner_speed_max.max(speed);
        if speed > PARTNER_SPEED_MAX {
            self.partner_fast += 1;
        }
        let touch_x = (ego.length + p.length) / 2.0;
        let touch_y = (ego.width + p.width) / 2.0;
        let inside = p.x.abs() < touch_x && p.y.abs() < touch_y;
        if inside {
            self.overlaps += 1;
            let depth = touch_x - p.x.abs();
            if self
                .deepest_overlap
                .is_none_or(|(x, _, t)| depth > t - x.abs())
            {
                self.deepest_overlap = Some((p.x, p.y, touch_x));
            }
        }
        if p.x.abs() > FAR_X || p.y.abs() > FAR_Y {
            self.far += 1;
            if p.x.hypot(p.y) > self.farthest.0.hypot(self.farthest.1) {
                self.farthest = (p.x, p.y);
            }
        }
        if u.flags.has(InputFlags::SIZE_DEFAULT) {
            self.size_default += 1;
            self.default_size = Some((p.length, p.width));
        }
        self.follow(u, inside);
    }

    /// The side a track is first seen on, and its reported relative speed against its own
    /// position change (where the speed is sent, not derived from that same change).
    fn follow(&mut self, u: &ScoredUpdate, inside: bool) {
        let (x, y) = (f64::from(u.partner.x), f64::from(u.partner.y));
        let side = if y > 1.0 {
            1
        } else if y < -1.0 {
            -1
        } else {
            0
        };
        let full = self.followed.len() >= FOLLOWED_TRACKS;
        let Some(f) = (match self.followed.get_mut(&u.track) {
            Some(f) => Some(f),
            None if full => None,
            None => {
                self.followed.insert(
                    u.track,
                    Followed {
                        t_us: u.t_us,
                        x,
                        y,
                        side: 0,
                        inside_since_us: None,
                    },
                );
                self.followed.get_mut(&u.track)
            }
        }) else {
            return;
        };
        match (inside, f.inside_since_us) {
            (false, _) => f.inside_since_us = None,
            (true, None) => f.inside_since_us = Some(u.t_us),
            (true, Some(since)) => {
                if u.t_us.saturating_sub(since) >= INSIDE_PERSISTENT_US {
                    self.inside_tracks += 1;
                    // Counted once per run inside.
                    f.inside_since_us = Some(u64::MAX);
                }
            }
        }
        if f.side == 0 && side != 0 {
            f.side = side;
            if side > 0 {
                self.left += 1;
            } else {
                self.right += 1;
            }
        }
        let dt = u.t_us.saturating_sub(f.t_us) as f64 / 1e6;
        if dt < MOTION_MIN_DT {
            return;
        }
        if dt <= 1.0 {
            let lat_sent = !u.flags.has(InputFlags::VEL_LAT_DERIVED)
                && !u.flags.has(InputFlags::VEL_LAT_DEFAULT);
            let long_sent = !u.flags.has(InputFlags::VEL_LONG_DERIVED)
                && !u.flags.has(InputFlags::VEL_LONG_DEFAULT);
            let moved_y = (y - f.y) / dt;
            let reported_y = f64::from(u.partner.vy - u.ego.vy);
            if lat_sent && moved_y.abs() > MOTION_MIN_SPEED && reported_y.abs() > MOTION_MIN_SPEED {
                self.lat_compared += 1;
                if moved_y.signum() != reported_y.signum() {
                    self.lat_opposite += 1;
                }
            }
            let moved_x = (x - f.x) / dt;
            let reported_x = f64::from(u.partner.vx - u.ego.vx);
            if long_sent && moved_x.abs() > 1.0 && self.long_ratios.len() < 100_000 {
                self.long_ratios.push((reported_x / moved_x) as f32);
            }
        }
        (f.t_us, f.x, f.y) = (u.t_us, x, y);
    }

    /// The warnings, one line each (empty when nothing looked wrong).
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.updates == 0 {
            return w;
        }
        let share = |n: u64| 100.0 * n as f64 / self.updates as f64;
        if self.ego_fast > 0 {
            w.push(format!(
                "ego speed up to {:.1} m/s ({:.1} % of the scored updates above {EGO_SPEED_MAX} m/s); an ego speed in km/h mapped without factor 1/3.6 usually causes this (as km/h it would be {:.1} m/s)",
                self.ego_speed_max,
                share(self.ego_fast),
                self.ego_speed_max / 3.6
            ));
        }
        if self.partner_fast > 0 {
            w.push(format!(
                "partners move at up to {:.1} m/s over ground ({:.1} % of the updates above {PARTNER_SPEED_MAX} m/s); an object or ego speed in km/h (factor 1/3.6 missing), a relative velocity mapped as `velocity = \"absolute\"` (or the reverse) or a velocity sign flipped usually causes this",
                self.partner_speed_max,
                share(self.partner_fast)
            ));
        }
        if let (Some((x, y, touch)), true) = (self.deepest_overlap, self.inside_tracks > 0) {
            w.push(format!(
                "{} tracks stayed inside the ego's box for {} s or longer ({} updates, {:.1} %, inside), deepest at x {x:.2} m, y {y:.2} m ({:.2} m past touching at |x| = {touch:.2} m); a missing sensor offset (`[sensor] x`, e.g. the radar's distance from the ego centre) or a near-face distance mapped without its `offset` usually causes this",
                self.inside_tracks,
                INSIDE_PERSISTENT_US / 1_000_000,
                self.overlaps,
                share(self.overlaps),
                touch - x.abs()
            ));
        }
        if self.far > 0 {
            w.push(format!(
                "{} updates ({:.1} %) beyond {FAR_X} m ahead/behind or {FAR_Y} m to the side, farthest at x {:.1} m, y {:.1} m; a distance in cm or dm, or a wrong factor, usually causes this",
                self.far,
                share(self.far),
                self.farthest.0,
                self.farthest.1
            ));
        }
        if self.size_default == self.updates {
            if let Some((l, wd)) = self.default_size {
                w.push(format!(
                    "every partner was scored with the default size {l} x {wd} m (no length/width mapped or sent); trucks and buses are scored as cars, which delays their warnings"
                ));
            }
        }
        let sided = self.left + self.right;
        if sided >= 10 {
            let (most, side, sign) = if self.left >= self.right {
                (self.left, "left (y > 0)", "left")
            } else {
                (self.right, "right (y < 0)", "right")
            };
            if most as f64 >= 0.9 * sided as f64 {
                w.push(format!(
                    "{most} of {sided} tracks first appeared on the {side}; unless the ego drove in the outermost lane, a missing lateral sensor offset (`[sensor] y`) or a wrong lateral sign (`factor = -1` on object.pos_y) usually causes this: check that a target known to be on the {sign} comes out there (`can-bridge decode`)"
                ));
            }
        }
        if self.lat_compared >= 20 && self.lat_opposite * 2 > self.lat_compared {
            w.push(format!(
                "the lateral speed the sensor sends has the opposite sign of the tracks' lateral position change in {} of {} comparisons ({:.0} %); object.pos_y and object.vel_y use opposite sign conventions: one of them needs `factor = -1`",
                self.lat_opposite,
                self.lat_compared,
                100.0 * self.lat_opposite as f64 / self.lat_compared as f64
            ));
        }
        if self.long_ratios.len() >= 20 {
            let mut r = self.long_ratios.clone();
            r.sort_unstable_by(f32::total_cmp);
            let median = r[r.len() / 2];
            if !(0.5..=2.0).contains(&median) {
                w.push(format!(
                    "the longitudinal relative speed the sensor sends is {median:.2} times the tracks' position change (median of {} comparisons); a speed or distance in another unit (km/h: 3.6x), a sign flipped (negative) or a relative velocity mapped as absolute usually causes this",
                    r.len()
                ));
            }
        }
        w
    }

    /// Prints the warnings on stderr, each prefixed with `who`.
    pub fn print(&self, who: &str) {
        for line in self.warnings() {
            eprintln!("{who}: sanity: {line}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scorer_core::VehicleState;

    fn car(x: f32, y: f32, vx: f32) -> VehicleState {
        VehicleState {
            x,
            y,
            vx,
            vy: 0.0,
            hx: 1.0,
            hy: 0.0,
            acc: 0.0,
            length: 4.5,
            width: 1.8,
        }
    }

    fn update(t_us: u64, track: u32, ego_vx: f32, partner: VehicleState) -> ScoredUpdate {
        ScoredUpdate {
            t_us,
            track,
            ego: car(0.0, 0.0, ego_vx),
            partner,
            flags: InputFlags::default(),
            score: 0.0,
            warning: false,
            level: 0,
        }
    }

    fn warnings_of(updates: &[ScoredUpdate]) -> Vec<String> {
        let mut s = Sanity::default();
        for u in updates {
            s.observe(u);
        }
        s.warnings()
    }

    #[test]
    fn plausible_traffic_gives_no_warning() {
        let updates: Vec<_> = (0..40)
            .map(|k| {
                update(
                    k * 100_000,
                    (k % 4) as u32,
                    25.0,
                    car(30.0, 3.5 - 7.0 * (k % 2) as f32, 24.0),
                )
            })
            .collect();
        assert_eq!(warnings_of(&updates), Vec::<String>::new());
    }

    #[test]
    fn a_km_h_ego_speed_and_its_partners_are_named_with_their_size() {
        // 90 km/h read as m/s; the relative partner speed then adds up to 90 m/s over ground too.
        let w = warnings_of(&[update(0, 1, 90.0, car(30.0, 0.0, 92.0))]);
        assert!(
            w[0].starts_with("ego speed up to 90.0 m/s (100.0 %"),
            "{w:?}"
        );
        assert!(w[0].contains("25.0 m/s"), "{w:?}");
        assert!(w[1].starts_with("partners move at up to 92.0 m/s"), "{w:?}");
    }

    #[test]
    fn far_positions_and_one_sided_traffic_are_named() {
        let mut updates = vec![update(0, 1, 20.0, car(3000.0, 0.0, 20.0))];
        updates
            .extend((0..12).map(|k| update(1000 + k, 10 + k as u32, 20.0, car(20.0, 3.0, 20.0))));
        let w = warnings_of(&updates);
        assert!(
            w.iter()
                .any(|l| l.contains("beyond 1000 m") && l.contains("x 3000.0 m")),
            "{w:?}"
        );
        assert!(
            w.iter()
                .any(|l| l.starts_with("12 of 12 tracks first appeared on the left")),
            "{w:?}"
        );
    }
}
