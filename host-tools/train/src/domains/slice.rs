//! Where in the operating domain one sequence lies: the ego's speed band and the interaction
//! geometry at its reference frame, and the source it came from.
//!
//! The reference frame is the moment that matters for the sequence's label: the endpoint of a
//! conflict (impact or safety-critical frame: the last frame of its alert window) or, for a safe
//! sequence, the frame of closest approach (smallest box distance, the first one on a tie). The
//! geometry is scorer-core's [`interaction::geometry`] at that frame, the one definition the
//! importer and the simulator use too.
use std::fmt;

use scorer_core::geometry::box_distance;
use scorer_core::interaction::{self, Geometry};

use super::source::Source;
use riskscore_data::events::{Frame, Sequence};

/// An ego speed band (m/s) of the operating domain: lower edge inclusive, upper edge exclusive,
/// except the top band, which includes 50 m/s. Faster than that is outside the domain (no band).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SpeedBand {
    Crawl,
    Urban,
    Arterial,
    Freeway,
    Motorway,
}

impl SpeedBand {
    /// Every band, slowest first.
    pub const ALL: [SpeedBand; 5] = [
        SpeedBand::Crawl,
        SpeedBand::Urban,
        SpeedBand::Arterial,
        SpeedBand::Freeway,
        SpeedBand::Motorway,
    ];

    /// `(lower, upper)` edges in m/s.
    pub const fn edges(self) -> (f32, f32) {
        match self {
            SpeedBand::Crawl => (0.0, 5.0),
            SpeedBand::Urban => (5.0, 15.0),
            SpeedBand::Arterial => (15.0, 25.0),
            SpeedBand::Freeway => (25.0, 35.0),
            SpeedBand::Motorway => (35.0, 50.0),
        }
    }

    /// The band of a speed (m/s); `None` for a negative, non-finite or above-50 m/s speed.
    pub fn of(speed: f32) -> Option<SpeedBand> {
        SpeedBand::ALL.into_iter().find(|b| {
            let (lo, hi) = b.edges();
            speed >= lo && (speed < hi || (*b == SpeedBand::Motorway && speed <= hi))
        })
    }

    /// `35-50` (the edges, as the round names and reports spell them).
    pub fn label(self) -> String {
        let (lo, hi) = self.edges();
        format!("{lo}-{hi}")
    }
}

impl fmt::Display for SpeedBand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} m/s", self.label())
    }
}

/// One sequence's place in the domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Domain {
    /// Ego speed band at the reference frame; `None` above 50 m/s or without frames.
    pub band: Option<SpeedBand>,
    /// Geometry at the reference frame; `None` when the core defines none (no ego heading).
    pub geometry: Option<Geometry>,
    pub source: Source,
}

/// The frame a sequence is sliced at: the endpoint frame of a conflict, the closest approach of a
/// safe sequence. `None` without frames (or a conflict without a frame up to its endpoint).
pub fn reference_frame(sequence: &Sequence) -> Option<&Frame> {
    if sequence.is_conflict() {
        return sequence.alert_frames().last();
    }
    sequence.frames.iter().reduce(|best, f| {
        if box_distance(&f.ego, &f.partner) < box_distance(&best.ego, &best.partner) {
            f
        } else {
            best
        }
    })
}

/// Slice one sequence of a known source.
pub fn domain_of(sequence: &Sequence, source: Source) -> Domain {
    let frame = reference_frame(sequence);
    Domain {
        band: frame.and_then(|f| SpeedBand::of(f.ego.vx.hypot(f.ego.vy))),
        geometry: frame.and_then(|f| interaction::geometry(&f.ego, &f.partner)),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use riskscore_data::events::EventKind;
    use scorer_core::VehicleState;

    fn car(x: f32, y: f32, vx: f32, vy: f32) -> VehicleState {
        let v = vx.hypot(vy).max(1e-3);
        VehicleState {
            x,
            y,
            vx,
            vy,
            hx: vx / v,
            hy: vy / v,
            acc: 0.0,
            length: 4.5,
            width: 1.8,
        }
    }

    fn frame(time: f64, ego: VehicleState, partner: VehicleState) -> Frame {
        Frame { time, ego, partner }
    }

    #[test]
    fn band_edges_belong_to_the_band_above_and_50_is_the_last() {
        assert_eq!(SpeedBand::of(0.0), Some(SpeedBand::Crawl));
        assert_eq!(SpeedBand::of(4.999), Some(SpeedBand::Crawl));
        assert_eq!(SpeedBand::of(5.0), Some(SpeedBand::Urban));
        assert_eq!(SpeedBand::of(15.0), Some(SpeedBand::Arterial));
        assert_eq!(SpeedBand::of(25.0), Some(SpeedBand::Freeway));
        assert_eq!(SpeedBand::of(34.99), Some(SpeedBand::Freeway));
        assert_eq!(SpeedBand::of(35.0), Some(SpeedBand::Motorway));
        assert_eq!(SpeedBand::of(50.0), Some(SpeedBand::Motorway));
        assert_eq!(SpeedBand::of(50.01), None);
        assert_eq!(SpeedBand::of(-0.1), None);
        assert_eq!(SpeedBand::of(f32::NAN), None);
        assert_eq!(SpeedBand::Motorway.label(), "35-50");
    }

    #[test]
    fn a_safe_sequence_is_sliced_at_its_closest_approach() {
        // The ego slows from 40 to 20 m/s while closing to 3 m, then falls back: the closest
        // frame (t = 1) has the ego at 20 m/s, so the band is 15-25, not 35-50.
        let mut s = Sequence::new("a/1", EventKind::Safe, None);
        s.frames.push(frame(
            0.0,
            car(0.0, 0.0, 40.0, 0.0),
            car(30.0, 0.0, 20.0, 0.0),
        ));
        s.frames.push(frame(
            1.0,
            car(0.0, 0.0, 20.0, 0.0),
            car(7.5, 0.0, 20.0, 0.0),
        ));
        s.frames.push(frame(
            2.0,
            car(0.0, 0.0, 45.0, 0.0),
            car(20.0, 0.0, 20.0, 0.0),
        ));
        assert_eq!(reference_frame(&s).map(|f| f.time), Some(1.0));
        let d = domain_of(&s, Source::RealFreeway);
        assert_eq!(d.band, Some(SpeedBand::Arterial));
        assert_eq!(d.geometry, Some(Geometry::Following));
    }

    #[test]
    fn a_conflict_is_sliced_at_its_endpoint_not_at_closest_approach() {
        // Closest approach comes after the endpoint (t = 2), but the endpoint frame (t = 1) rules:
        // a crossing partner, ego at 40 m/s.
        let mut s = Sequence::new("7", EventKind::Crash, Some(1.0));
        s.frames.push(frame(
            0.0,
            car(0.0, 0.0, 30.0, 0.0),
            car(40.0, -20.0, 0.0, 10.0),
        ));
        s.frames.push(frame(
            1.0,
            car(0.0, 0.0, 40.0, 0.0),
            car(20.0, -10.0, 0.0, 10.0),
        ));
        s.frames.push(frame(
            2.0,
            car(0.0, 0.0, 10.0, 0.0),
            car(6.0, 0.0, 10.0, 0.0),
        ));
        assert_eq!(reference_frame(&s).map(|f| f.time), Some(1.0));
        let d = domain_of(&s, Source::Sim);
        assert_eq!(d.band, Some(SpeedBand::Motorway));
        assert_eq!(d.geometry, Some(Geometry::Crossing));
    }

    #[test]
    fn oncoming_and_adjacent_geometry_and_no_frames() {
        let mut s = Sequence::new("b/2", EventKind::Safe, None);
        s.frames.push(frame(
            0.0,
            car(0.0, 0.0, 10.0, 0.0),
            car(40.0, 3.5, -10.0, 0.0),
        ));
        assert_eq!(
            domain_of(&s, Source::Sim).geometry,
            Some(Geometry::Oncoming)
        );
        s.frames[0].partner = car(10.0, 3.5, 10.0, 0.0);
        assert_eq!(
            domain_of(&s, Source::Sim).geometry,
            Some(Geometry::Adjacent)
        );
        let empty = Sequence::new("c/3", EventKind::Safe, None);
        let d = domain_of(&empty, Source::Sim);
        assert_eq!((d.band, d.geometry), (None, None));
    }
}
