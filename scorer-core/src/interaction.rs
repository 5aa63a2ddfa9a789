//! How a partner meets the ego: the interaction geometry of a pair (following, adjacent,
//! crossing, oncoming).
//!
//! One definition for every tool that slices, filters or reports by geometry (the real-data
//! importer's interaction rules, the domain benchmark, the simulator's coverage tests), so that
//! "crossing" means the same thing everywhere. Vector algebra only, no trigonometry:
//!
//! - the relative heading is read from `c = h_ego . h_partner` (unit headings): travelling the
//!   same way when `c >= cos 30 deg`, oncoming when `c <= -cos 30 deg`, crossing in between;
//! - travelling the same way, the partner is *following* geometry (same lane, ahead or behind)
//!   when its centre lies within [`SAME_LANE_HALF_WIDTH`] of the ego's centre line
//!   (`|dp x h_ego|`), else *adjacent*.
//!
//! A partner without a heading (a zero or non-finite `(hx, hy)`, e.g. a roadside object reported
//! without orientation) has no direction of travel; it is placed by its offset alone, as if it
//! pointed the ego's way. An ego without a heading, or a non-finite position, has no geometry.
//!
//! Limitation: the lateral offset is measured across the ego's current heading, so on a tight
//! curve a far partner in the same lane can read as adjacent. The thresholds are for roads with
//! lanes of 3.5-3.75 m.
use crate::geometry::{position, unit_heading};
use crate::state::VehicleState;

/// `cos 30 deg`: headings within 30 degrees travel the same way; beyond 150 degrees, oncoming.
pub const SAME_DIRECTION_COS: f32 = 0.866_025_4;

/// Largest lateral centre offset (m) across the ego's heading at which a partner travelling the
/// same way is in the ego's lane: half a 3.6 m lane.
pub const SAME_LANE_HALF_WIDTH: f32 = 1.8;

/// The interaction geometry of an ego/partner pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Geometry {
    /// Same direction, same lane: the partner ahead of or behind the ego.
    Following,
    /// Same direction, another lane (or beside the road).
    Adjacent,
    /// Paths crossing: relative heading between 30 and 150 degrees.
    Crossing,
    /// Opposite directions: relative heading beyond 150 degrees.
    Oncoming,
}

impl Geometry {
    /// Every geometry, in declaration order.
    pub const ALL: [Geometry; 4] = [
        Geometry::Following,
        Geometry::Adjacent,
        Geometry::Crossing,
        Geometry::Oncoming,
    ];

    /// The lower-case name used in files and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Geometry::Following => "following",
            Geometry::Adjacent => "adjacent",
            Geometry::Crossing => "crossing",
            Geometry::Oncoming => "oncoming",
        }
    }

    /// The geometry named `name` (as [`Geometry::as_str`] spells it), if any.
    pub fn from_name(name: &str) -> Option<Geometry> {
        Geometry::ALL.into_iter().find(|g| g.as_str() == name)
    }
}

/// The geometry of `partner` as seen from `ego`, or `None` when the ego has no heading or either
/// position is not finite.
pub fn geometry(ego: &VehicleState, partner: &VehicleState) -> Option<Geometry> {
    let h_ego = unit_heading(ego)?;
    let offset = position(partner) - position(ego);
    if !offset.is_finite() {
        return None;
    }
    let cos_heading = unit_heading(partner).map_or(1.0, |h| h_ego.dot(h));
    let geometry = if cos_heading <= -SAME_DIRECTION_COS {
        Geometry::Oncoming
    } else if cos_heading < SAME_DIRECTION_COS {
        Geometry::Crossing
    } else if libm::fabsf(offset.cross(h_ego)) <= SAME_LANE_HALF_WIDTH {
        Geometry::Following
    } else {
        Geometry::Adjacent
    };
    Some(geometry)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car(x: f32, y: f32, hx: f32, hy: f32) -> VehicleState {
        VehicleState {
            x,
            y,
            vx: 10.0 * hx,
            vy: 10.0 * hy,
            hx,
            hy,
            acc: 0.0,
            length: 4.5,
            width: 1.8,
        }
    }

    const EGO: (f32, f32, f32, f32) = (100.0, -20.0, 1.0, 0.0);

    fn ego() -> VehicleState {
        car(EGO.0, EGO.1, EGO.2, EGO.3)
    }

    #[test]
    fn same_lane_ahead_and_behind_is_following() {
        assert_eq!(
            geometry(&ego(), &car(130.0, -20.5, 1.0, 0.0)),
            Some(Geometry::Following)
        );
        assert_eq!(
            geometry(&ego(), &car(80.0, -18.3, 1.0, 0.02)),
            Some(Geometry::Following)
        );
    }

    #[test]
    fn the_next_lane_is_adjacent_on_either_side() {
        assert_eq!(
            geometry(&ego(), &car(105.0, -16.4, 1.0, 0.0)),
            Some(Geometry::Adjacent)
        );
        assert_eq!(
            geometry(&ego(), &car(95.0, -23.6, 1.0, 0.0)),
            Some(Geometry::Adjacent)
        );
    }

    #[test]
    fn the_lane_edge_is_inclusive() {
        let at_edge = car(110.0, -20.0 + SAME_LANE_HALF_WIDTH, 1.0, 0.0);
        assert_eq!(geometry(&ego(), &at_edge), Some(Geometry::Following));
        let beyond = car(110.0, -20.0 + SAME_LANE_HALF_WIDTH + 0.01, 1.0, 0.0);
        assert_eq!(geometry(&ego(), &beyond), Some(Geometry::Adjacent));
    }

    #[test]
    fn relative_heading_splits_same_way_crossing_and_oncoming() {
        let at = |deg: f32| {
            let r = deg.to_radians();
            geometry(&ego(), &car(120.0, -20.0, libm::cosf(r), libm::sinf(r)))
        };
        assert_eq!(at(25.0), Some(Geometry::Following));
        assert_eq!(at(35.0), Some(Geometry::Crossing));
        assert_eq!(at(-90.0), Some(Geometry::Crossing));
        assert_eq!(at(145.0), Some(Geometry::Crossing));
        assert_eq!(at(155.0), Some(Geometry::Oncoming));
        assert_eq!(at(-180.0), Some(Geometry::Oncoming));
    }

    #[test]
    fn heading_length_does_not_matter() {
        let long = VehicleState {
            hx: 5.0,
            hy: 5.0,
            ..car(120.0, -20.0, 0.0, 0.0)
        };
        assert_eq!(geometry(&ego(), &long), Some(Geometry::Crossing));
    }

    #[test]
    fn a_partner_without_heading_is_placed_by_its_offset() {
        let object = car(130.0, -14.0, 0.0, 0.0);
        assert_eq!(geometry(&ego(), &object), Some(Geometry::Adjacent));
        let in_lane = car(130.0, -20.0, f32::NAN, 0.0);
        assert_eq!(geometry(&ego(), &in_lane), Some(Geometry::Following));
    }

    #[test]
    fn no_geometry_without_an_ego_heading_or_finite_positions() {
        let no_heading = car(EGO.0, EGO.1, 0.0, 0.0);
        assert_eq!(geometry(&no_heading, &car(130.0, -20.0, 1.0, 0.0)), None);
        assert_eq!(geometry(&ego(), &car(f32::INFINITY, -20.0, 1.0, 0.0)), None);
        assert_eq!(geometry(&ego(), &car(130.0, f32::NAN, 1.0, 0.0)), None);
    }

    #[test]
    fn names_round_trip() {
        for g in Geometry::ALL {
            assert_eq!(Geometry::from_name(g.as_str()), Some(g));
        }
        assert_eq!(Geometry::from_name("merging"), None);
    }
}
