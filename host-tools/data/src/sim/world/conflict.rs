//! Crossing conflicts: where two paths meet, and when a yielding or priority driver stops for one.
use super::driver::{Driver, Snap};
use super::path::{Path, Pose};

/// Role of a vehicle at a crossing conflict zone.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Role {
    /// Gives way: goes when the partner's (misjudged) arrival leaves at least `margin` s after it
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
    pub partner_in: f64,
    pub partner_out: f64,
    pub role: Role,
}

/// How far a driver has got with a crossing: a yielding driver that `committed` goes through; a
/// priority driver `released` from the conflict no longer watches it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct CrossingProgress {
    pub committed: bool,
    pub released: bool,
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

/// Where the driver stops for a crossing conflict, if it does (yield and priority logic).
pub(super) fn conflict_stop(
    progress: &mut CrossingProgress,
    driver: &Driver,
    c: &Conflict,
    ms: &Snap,
    os: &Snap,
) -> Option<f64> {
    match c.role {
        Role::Yield {
            margin,
            misjudge,
            blind,
        } => {
            if progress.committed || blind {
                return None;
            }
            if ms.s >= c.me_in - 0.5 {
                progress.committed = true;
                return None;
            }
            let dist = c.me_in - ms.s;
            let decide_at = ms.v * ms.v / (2.0 * 0.6 * driver.b_comf) + 5.0;
            if dist > decide_at {
                return None;
            }
            let gone = os.s > c.partner_out;
            let inside = os.s >= c.partner_in && !gone;
            let accept = gone
                || (!inside && {
                    let t_o = (c.partner_in - os.s) / (os.v * misjudge).max(0.1);
                    let t_c = travel_time(c.me_out - ms.s, ms.v, driver.a_max, driver.v0);
                    t_o - t_c >= margin
                });
            if accept {
                progress.committed = true;
                None
            } else {
                // Stop line 2.5 m before the zone, clear of the partner's lane.
                Some(c.me_in - 2.5)
            }
        }
        Role::Priority { margin } => {
            if progress.released || os.s > c.partner_out {
                progress.released = true;
                return None;
            }
            if ms.s >= c.me_in - 0.5 {
                return None;
            }
            let inside = os.s >= c.partner_in;
            let d_o = c.partner_in - os.s;
            // Right of way: the partner is assumed to give way until it is close to the zone and
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
            let t_o_out = (c.partner_out - os.s) / ov;
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
    fn travel_time_accelerates_then_cruises() {
        // From 0 at 2 m/s^2 to 10 m/s: 5 s and 25 m, then 10 m/s.
        assert!((travel_time(25.0, 0.0, 2.0, 10.0) - 5.0).abs() < 1e-9);
        assert!((travel_time(45.0, 0.0, 2.0, 10.0) - 7.0).abs() < 1e-9);
        assert!((travel_time(9.0, 0.0, 2.0, 10.0) - 3.0).abs() < 1e-9);
        assert_eq!(travel_time(-1.0, 5.0, 1.0, 10.0), 0.0);
    }
}
