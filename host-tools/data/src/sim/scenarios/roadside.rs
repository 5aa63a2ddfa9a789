//! Passing a stationary object beside the lane on a straight road at 5-50 m/s: a parked vehicle
//! or a roadside object at 3-8 m lateral clearance (benign), or one that sticks 0.2-1.2 m into
//! the path of a driver who sees it late (hazardous).
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::parts::{
    agent, distracted_until, driver, scripted, sign, u, Built, Vehicle, VehicleClass, CRUISE,
};
use crate::events::LENGTH_RANGE_M;
use crate::sim::world::Path;

/// Ego speeds (m/s) of the family: the whole speed range of the operating domain above walking.
const V_EGO: (f64, f64) = (5.0, 50.0);

/// The ego (always the moving vehicle) drives straight at constant speed past a stationary
/// object: a parked vehicle (65 %, the drawn partner) or a non-vehicle object (35 %: 0.5-2.5 m
/// long, 0.3-1.5 m wide), on the right (75 %) or left. Benign: lateral clearance (edge to edge)
/// U(3, 8) m; the object is outside the driver's corridor and nobody reacts to it. Hazardous: the
/// object reaches 0.2-1.2 m into the ego's path; the driver is distracted until a time to contact
/// of 0.6-3 s and then brakes, and swerves away with p = 0.6. Returns the object's class.
pub(super) fn roadside_object(
    rng: &mut ChaCha8Rng,
    hz: bool,
    ego: &Vehicle,
    partner: &Vehicle,
) -> (Built, VehicleClass) {
    let object = if rng.random_bool(0.35) {
        Vehicle {
            class: VehicleClass::Object,
            // Drawn from 0.4 m and raised to the event format's (and the CAN signal's) shortest
            // box, 0.5 m: the loader drops shorter ones, and the same draw keeps every other
            // event of a seed as it was.
            dims: (
                u(rng, 0.4, 2.5).max(f64::from(LENGTH_RANGE_M.0)),
                u(rng, 0.3, 1.5),
            ),
            limits: (0.0, 0.0),
        }
    } else {
        *partner
    };
    let v = u(rng, V_EGO.0, V_EGO.1);
    let side = if rng.random_bool(0.75) { -1.0 } else { 1.0 };
    let heading = if object.class == VehicleClass::Object {
        u(rng, -0.5, 0.5)
    } else {
        sign(rng) * u(rng, 0.0, 0.05)
    };
    // Half the ego's width plus the object's lateral half extent as it stands (rotated box).
    let (length, width) = object.dims;
    let half_widths =
        0.5 * ego.dims.1 + 0.5 * (length * heading.sin().abs() + width * heading.cos());
    let lateral = if hz {
        half_widths - u(rng, 0.2, 1.2)
    } else {
        half_widths + u(rng, 3.0, 8.0)
    };
    let t_pass = u(rng, 6.0, 10.0);
    let mut ed = driver(rng, hz, v, (1.0, 1.08));
    ed.v0 = ed.v0.min(V_EGO.1).max(v);
    if hz {
        let wake = u(rng, 0.6, 3.0);
        distracted_until(&mut ed, t_pass - wake);
        ed.swerve = rng.random_bool(0.6).then(|| crate::sim::world::Swerve {
            dir: -side,
            dd: u(rng, 0.8, 2.2),
            alat: u(rng, 3.0, 7.0),
            trigger: u(rng, 3.0, 6.0),
        });
    } else {
        ed.swerve = None;
    }
    let e = agent(Path::line(0.0, 0.0, 0.0), 0.0, v, ego, ed);
    let (od, script) = scripted(rng, 0.1, vec![(0.0, CRUISE)]);
    let x_o = v * t_pass + 0.5 * (ego.dims.0 + object.dims.0);
    let mut o = agent(
        Path::line(x_o, side * lateral, heading),
        0.0,
        0.0,
        &object,
        od,
    );
    o.script = Some(script);
    let horizon = t_pass + u(rng, 1.5, 3.0);
    ((e, o, horizon, true), object.class)
}
