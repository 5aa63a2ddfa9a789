//! Safe passes beside stationary roadside objects: the training-only data that teaches DRL a
//! parked object beside the lane is not a conflict (`riskctl roadside-passes`, docs/training.md).
//!
//! The ego drives a straight lane at constant speed past a stationary object, either side, from
//! 150 m before it (or 40 s before, whichever is nearer) to 30 m past it at 10 Hz: the geometry of
//! tests/tests/roadside_objects.rs on a grid DISJOINT from the test's (no speed, clearance or object
//! of the test), so the test measures whether what a model learns here generalises.
use scorer_core::VehicleState;

use crate::events::{Dims, Event, EventKind, Frame};

/// Ego speeds (m/s). The test drives 1, 3, 5, 8, 10, 15, ..., 50: none of them is here.
pub const SPEEDS: [f32; 20] = [
    2.0, 4.0, 6.0, 7.0, 9.0, 12.0, 14.0, 17.0, 19.0, 22.0, 24.0, 27.0, 29.0, 32.0, 34.0, 37.0,
    39.0, 42.0, 44.0, 47.0,
];
/// Lateral gap between the two boxes (m). The test uses 3, 3.5, 4.5 and 6.
pub const CLEARANCES: [f32; 4] = [3.25, 4.0, 5.0, 7.0];
/// Name, length and width (m) of the object. The test passes a parked car, a post and a truck.
pub const OBJECTS: [(&str, f32, f32); 3] = [
    ("van", 6.0, 2.2),
    ("object", 1.0, 1.0),
    ("trailer", 16.5, 2.55),
];
const EGO_LENGTH: f32 = 4.5;
const EGO_WIDTH: f32 = 1.8;
/// Frame interval of a pass (s).
pub const DT: f64 = 0.1;

fn state(x: f32, y: f32, v: f32, length: f32, width: f32) -> VehicleState {
    VehicleState {
        x,
        y,
        vx: v,
        vy: 0.0,
        hx: 1.0,
        hy: 0.0,
        acc: 0.0,
        length,
        width,
    }
}

/// Every pass of the grid, as safe events with ids `roadside/<object>-<clearance>m-<side>-<v>mps` (clearance with
/// one decimal at least, as the Python script it replaced wrote them: `van-4.0m-left-12mps`).
pub fn roadside_passes() -> Vec<Event> {
    let mut events = Vec::new();
    for (name, length, width) in OBJECTS {
        for clearance in CLEARANCES {
            for (side, side_name) in [(-1.0f32, "right"), (1.0, "left")] {
                let object = roadside_object(length, width, clearance, side);
                for v in SPEEDS {
                    events.push(pass(name, object, clearance, side_name, v));
                }
            }
        }
    }
    events
}

/// A stationary `length` x `width` object `clearance` m (box to box) beside the ego's lane, on
/// the right (`side` -1) or the left (+1), level with the origin.
pub fn roadside_object(length: f32, width: f32, clearance: f32, side: f32) -> VehicleState {
    let y = side * (clearance + (width + EGO_WIDTH) / 2.0);
    state(0.0, y, 0.0, length, width)
}

/// The frames of one pass: the ego (4.5 x 1.8 m) at `v` m/s along the x axis past `object`, from
/// 150 m before it (or 40 s before, whichever is nearer) to 30 m past it, every [`DT`] s.
pub fn pass_frames(v: f32, object: VehicleState) -> Vec<Frame> {
    let start = (-150.0f64).max(-40.0 * f64::from(v));
    let step = f64::from(v) * DT;
    let frame_count = ((30.0 - start) / step).ceil() as usize;
    (0..=frame_count)
        .map(|k| Frame {
            time: k as f64 * DT,
            ego: state(
                (start + step * k as f64) as f32,
                0.0,
                v,
                EGO_LENGTH,
                EGO_WIDTH,
            ),
            partner: object,
        })
        .collect()
}

fn pass(name: &str, object: VehicleState, clearance: f32, side_name: &str, v: f32) -> Event {
    let frames = pass_frames(v, object);
    let (length, width) = (object.length, object.width);
    Event {
        id: format!("roadside/{name}-{clearance:?}m-{side_name}-{v}mps"),
        kind: EventKind::Safe,
        t_start: 0.0,
        t_end: frames.last().map_or(0.0, |f| f.time),
        t_impact: None,
        dims: Dims {
            length_ego: EGO_LENGTH,
            width_ego: EGO_WIDTH,
            length_partner: length,
            width_partner: width,
        },
        frames,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pass_runs_from_before_the_object_to_30_m_past_it_at_its_clearance() {
        let passes = roadside_passes();
        assert_eq!(
            passes.len(),
            SPEEDS.len() * CLEARANCES.len() * OBJECTS.len() * 2
        );
        for e in &passes {
            let (first, last) = (e.frames.first().unwrap(), e.frames.last().unwrap());
            let v = first.ego.vx;
            assert!(first.ego.x <= -f32::min(150.0, 40.0 * v) + 1e-3, "{}", e.id);
            assert!(
                last.ego.x >= 30.0 && last.ego.x < 30.0 + v * 0.1 + 1e-3,
                "{}",
                e.id
            );
            let gap = (first.partner.y.abs() - (first.partner.width + EGO_WIDTH) / 2.0) * 10.0;
            assert!(
                CLEARANCES.iter().any(|c| (c * 10.0 - gap).abs() < 1e-3),
                "{}: gap {}",
                e.id,
                gap / 10.0
            );
            assert!(e.frames.windows(2).all(|w| w[1].time > w[0].time));
        }
    }
}
