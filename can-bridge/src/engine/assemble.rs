//! Pure state assembly: the ego's and a track's received inputs turned into the core's ego and
//! partner [`VehicleState`] for one scoring cycle (no outputs, no counters, no warning state).
//!
//! Object kinematics (documented in docs/can-bridge.md): Cartesian or polar positions in the
//! sensor frame, rotated and shifted by the sensor mounting into the ego frame; velocity components
//! the sensor does not send are taken from the track's own motion (position change over the map's
//! window) or are zero; relative velocities get the ego velocity added.
use super::flags::InputFlags;
use super::track::{update_motion, PartnerSlots, Stamped};
use crate::map::{
    CompiledMap, EgoField, MissingVelocity, PartnerField, PositionKind, VelocityFrame, EGO_FIELDS,
};
use scorer_core::VehicleState;

/// Speed (m/s) above which a partner's heading may be taken from its velocity.
pub const HEADING_FROM_VELOCITY_MIN_SPEED: f32 = 0.5;

/// Why a track update gives no state to score, in the order the checks run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Unscored {
    /// A second trigger for the track at the same timestamp.
    Duplicate,
    /// The map has a valid flag, but it is missing or stale.
    ValidFlagMissing,
    /// The sensor flags the object invalid.
    Invalid,
    /// The ego speed is missing or stale.
    EgoSpeedMissing,
    /// A required object input is missing or stale.
    InputMissing(PartnerField),
    /// The object is outside the map's field of view.
    OutsideView,
    /// The velocity derived from the track's motion is not known yet.
    MotionPending,
    /// The state is not finite or has a non-positive size.
    BadState,
}

impl Unscored {
    /// The ego speed was present: its check had passed when this stopped the update.
    pub fn after_ego_speed(self) -> bool {
        matches!(
            self,
            Self::InputMissing(_) | Self::OutsideView | Self::MotionPending | Self::BadState
        )
    }
}

/// The ego and the partner of one scoring cycle.
pub(super) struct States {
    pub ego: VehicleState,
    pub partner: VehicleState,
    pub flags: InputFlags,
}

/// The states of `track` at its trigger at `t_us`, from inputs at most `stale_us` old.
///
/// Updates what the track carries from cycle to cycle: its motion window, and (once its position
/// is known) its last heading and trigger time; clears its `waiting_reported` once every required
/// input is there.
pub(super) fn assemble(
    map: &CompiledMap,
    stale_us: u64,
    ego_inputs: &[Option<Stamped>; EGO_FIELDS],
    track: &mut PartnerSlots,
    t_us: u64,
) -> Result<States, Unscored> {
    if track.last_trigger_us == Some(t_us) {
        return Err(Unscored::Duplicate);
    }
    let has = map.has_partner_field;
    let values = track.values;
    let partner = |f: PartnerField| values[f as usize];
    let value = |f: PartnerField| Stamped::fresh(partner(f), t_us, stale_us);
    if has[PartnerField::Valid as usize] {
        match value(PartnerField::Valid) {
            Some(v) if v != 0.0 => {}
            None => return Err(Unscored::ValidFlagMissing),
            Some(_) => return Err(Unscored::Invalid),
        }
    }
    let ego_value = |f: EgoField| Stamped::fresh(ego_inputs[f as usize], t_us, stale_us);
    let Some(ego_vx) = ego_value(EgoField::VelLong) else {
        return Err(Unscored::EgoSpeedMissing);
    };
    let (pos_fields, vel_field) = match map.position {
        PositionKind::Cartesian => ([PartnerField::PosX, PartnerField::PosY], PartnerField::VelX),
        PositionKind::Polar => (
            [PartnerField::Range, PartnerField::Azimuth],
            PartnerField::RangeRate,
        ),
    };
    let required = pos_fields
        .into_iter()
        .chain([vel_field, PartnerField::VelX, PartnerField::VelY])
        .filter(|f| has[*f as usize]);
    for f in required {
        if value(f).is_none() {
            return Err(Unscored::InputMissing(f));
        }
    }
    track.waiting_reported = false;
    let (p_sensor, line_of_sight) = sensor_position(map, value);
    if !map.fov.contains(p_sensor) {
        return Err(Unscored::OutsideView);
    }
    let position = map.mount.place(p_sensor);
    let derive = map.missing_velocity == Some(MissingVelocity::TrackMotion);
    let derived = if derive {
        update_motion(
            &mut track.motion,
            t_us,
            position,
            map.motion_window_us,
            stale_us,
            ego_value(EgoField::YawRate),
        )
    } else {
        None
    };
    let complete = has[PartnerField::VelX as usize] && has[PartnerField::VelY as usize];
    if derive && !complete && derived.is_none() {
        return Err(Unscored::MotionPending);
    }
    let (vx, vy) = velocity(map, complete, line_of_sight, derived, value);
    let mut flags = InputFlags::default();
    let sent = |f: PartnerField| complete || has[f as usize];
    let polar_radial = line_of_sight.is_some() && has[PartnerField::RangeRate as usize];
    for (is_sent, derived_flag, default_flag) in [
        (
            sent(PartnerField::VelX) || polar_radial,
            InputFlags::VEL_LONG_DERIVED,
            InputFlags::VEL_LONG_DEFAULT,
        ),
        (
            sent(PartnerField::VelY),
            InputFlags::VEL_LAT_DERIVED,
            InputFlags::VEL_LAT_DEFAULT,
        ),
    ] {
        flags.set(derived_flag, !is_sent && derived.is_some());
        flags.set(default_flag, !is_sent && derived.is_none());
    }
    let ego_vy = ego_value(EgoField::VelLat);
    let ego_acc = ego_value(EgoField::Accel);
    flags.set(InputFlags::EGO_VEL_LAT_DEFAULT, ego_vy.is_none());
    flags.set(InputFlags::EGO_ACCEL_DEFAULT, ego_acc.is_none());
    flags.set(
        InputFlags::EGO_SIZE_DEFAULT,
        ego_inputs[EgoField::Length as usize].is_none()
            || ego_inputs[EgoField::Width as usize].is_none(),
    );
    let (ego_vy, ego_acc) = (ego_vy.unwrap_or(0.0), ego_acc.unwrap_or(0.0));
    let ego_len =
        ego_inputs[EgoField::Length as usize].map_or(map.ego_defaults.0, |s| s.value as f32);
    let ego_wid =
        ego_inputs[EgoField::Width as usize].map_or(map.ego_defaults.1, |s| s.value as f32);
    let ego = VehicleState {
        x: 0.0,
        y: 0.0,
        vx: ego_vx as f32,
        vy: ego_vy as f32,
        hx: 1.0,
        hy: 0.0,
        acc: ego_acc as f32,
        length: ego_len,
        width: ego_wid,
    };
    let (abs_vx, abs_vy) = match map.velocity {
        VelocityFrame::Relative => ((vx + ego_vx) as f32, (vy + ego_vy) as f32),
        VelocityFrame::Absolute => (vx as f32, vy as f32),
    };
    let heading_valid = !has[PartnerField::HeadingValid as usize]
        || value(PartnerField::HeadingValid).is_some_and(|v| v != 0.0);
    let heading = match value(PartnerField::Heading) {
        Some(h) if heading_valid => Some((libm::cos(h) as f32, libm::sin(h) as f32)),
        _ => {
            let speed = libm::hypotf(abs_vx, abs_vy);
            let from_velocity = speed >= HEADING_FROM_VELOCITY_MIN_SPEED;
            flags.set(InputFlags::HEADING_FROM_VELOCITY, from_velocity);
            from_velocity.then(|| (abs_vx / speed, abs_vy / speed))
        }
    };
    flags.set(
        InputFlags::HEADING_HELD,
        heading.is_none() && track.last_heading.is_some(),
    );
    flags.set(
        InputFlags::HEADING_DEFAULT,
        heading.is_none() && track.last_heading.is_none(),
    );
    let (hx, hy) = heading.or(track.last_heading).unwrap_or((1.0, 0.0));
    let accel = value(PartnerField::Accel);
    flags.set(InputFlags::ACCEL_DEFAULT, accel.is_none());
    flags.set(
        InputFlags::SIZE_DEFAULT,
        partner(PartnerField::Length).is_none() || partner(PartnerField::Width).is_none(),
    );
    let partner = VehicleState {
        x: position.0 as f32,
        y: position.1 as f32,
        vx: abs_vx,
        vy: abs_vy,
        hx,
        hy,
        acc: match accel {
            Some(a) if map.accel_relative => (a + ego_acc) as f32,
            Some(a) => a as f32,
            None => 0.0,
        },
        length: partner(PartnerField::Length).map_or(map.partner_defaults.0, |s| s.value as f32),
        width: partner(PartnerField::Width).map_or(map.partner_defaults.1, |s| s.value as f32),
    };
    track.last_trigger_us = Some(t_us);
    track.last_heading = Some((hx, hy));
    let sizes_positive =
        ego.length > 0.0 && ego.width > 0.0 && partner.length > 0.0 && partner.width > 0.0;
    if !(ego.is_finite() && partner.is_finite() && sizes_positive) {
        return Err(Unscored::BadState);
    }
    Ok(States {
        ego,
        partner,
        flags,
    })
}

/// The object's position in the sensor frame, and its line of sight from the sensor (polar maps:
/// `(cos, sin)` of the azimuth).
fn sensor_position(
    map: &CompiledMap,
    value: impl Fn(PartnerField) -> Option<f64>,
) -> ((f64, f64), Option<(f64, f64)>) {
    let (p_sensor, line_of_sight) = match map.position {
        PositionKind::Cartesian => (
            (
                value(PartnerField::PosX).unwrap_or(0.0),
                value(PartnerField::PosY).unwrap_or(0.0),
            ),
            None,
        ),
        PositionKind::Polar => {
            let r = value(PartnerField::Range).unwrap_or(0.0);
            let az = value(PartnerField::Azimuth).unwrap_or(0.0);
            let (c, s) = (libm::cos(az), libm::sin(az));
            ((r * c, r * s), Some((c, s)))
        }
    };
    (p_sensor, line_of_sight)
}

/// The object's velocity in the ego frame, as the map's velocity frame has it: as sent when the
/// map has both components, else completed from the range rate and/or the track's own motion
/// (`derived`, ego frame), else zero.
fn velocity(
    map: &CompiledMap,
    complete: bool,
    line_of_sight: Option<(f64, f64)>,
    derived: Option<(f64, f64)>,
    value: impl Fn(PartnerField) -> Option<f64>,
) -> (f64, f64) {
    let mount = map.mount;
    let d = mount.unrotate(derived.unwrap_or((0.0, 0.0)));
    let v_sensor = match (line_of_sight, value(PartnerField::RangeRate)) {
        _ if complete => (
            value(PartnerField::VelX).unwrap_or(0.0),
            value(PartnerField::VelY).unwrap_or(0.0),
        ),
        (Some((c, s)), Some(rr)) => {
            // Radial from the sensor, tangential from the track's motion (or zero).
            let tangential = -d.0 * s + d.1 * c;
            (rr * c - tangential * s, rr * s + tangential * c)
        }
        _ => (
            value(PartnerField::VelX).unwrap_or(d.0),
            value(PartnerField::VelY).unwrap_or(d.1),
        ),
    };
    mount.rotate(v_sensor)
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: u64 = 10_000_000;
    const STALE: u64 = 500_000;

    fn stamped(value: f64, t_us: u64) -> Option<Stamped> {
        Some(Stamped { value, t_us })
    }

    /// The project map's inputs of one healthy track and an ego at 10 m/s, all received at `T`.
    fn inputs() -> ([Option<Stamped>; EGO_FIELDS], PartnerSlots) {
        let mut ego = [None; EGO_FIELDS];
        ego[EgoField::VelLong as usize] = stamped(10.0, T);
        let mut track = PartnerSlots::default();
        for (f, v) in [
            (PartnerField::PosX, 20.0),
            (PartnerField::PosY, 1.5),
            (PartnerField::VelX, -4.0),
            (PartnerField::VelY, 0.0),
            (PartnerField::Valid, 1.0),
            (PartnerField::Heading, 0.3),
            (PartnerField::HeadingValid, 0.0),
        ] {
            track.values[f as usize] = stamped(v, T);
        }
        (ego, track)
    }

    #[test]
    fn relative_velocity_gets_the_ego_velocity_and_an_invalid_heading_follows_the_motion() {
        let (_db, map) = CompiledMap::project_default().unwrap();
        let (ego, mut track) = inputs();
        let s = assemble(&map, STALE, &ego, &mut track, T).unwrap();
        assert_eq!((s.ego.vx, s.ego.hx, s.ego.length), (10.0, 1.0, 4.5));
        assert_eq!((s.partner.x, s.partner.y), (20.0, 1.5));
        // 10 m/s ego + -4 m/s relative; the sent heading is flagged invalid: taken from the
        // velocity over ground, not 0.3 rad.
        assert_eq!((s.partner.vx, s.partner.vy), (6.0, 0.0));
        assert_eq!((s.partner.hx, s.partner.hy), (1.0, 0.0));
        assert_eq!((s.partner.length, s.partner.width), (4.5, 1.8));
        assert_eq!(track.last_trigger_us, Some(T));
        assert_eq!(track.last_heading, Some((1.0, 0.0)));
        // The same trigger time again is a duplicate.
        let again = assemble(&map, STALE, &ego, &mut track, T).err();
        assert_eq!(again, Some(Unscored::Duplicate));
    }

    #[test]
    fn missing_stale_and_invalid_inputs_say_why_in_check_order() {
        let (_db, map) = CompiledMap::project_default().unwrap();
        let run = |edit: &dyn Fn(&mut [Option<Stamped>; EGO_FIELDS], &mut PartnerSlots)| {
            let (mut ego, mut track) = inputs();
            edit(&mut ego, &mut track);
            assemble(&map, STALE, &ego, &mut track, T).err()
        };
        let valid = PartnerField::Valid as usize;
        assert_eq!(
            run(&|_, t| t.values[valid] = stamped(0.0, T)),
            Some(Unscored::Invalid)
        );
        assert_eq!(
            run(&|_, t| t.values[valid] = stamped(1.0, T - STALE - 1)),
            Some(Unscored::ValidFlagMissing)
        );
        // The ego speed is checked before the object's inputs.
        assert_eq!(
            run(&|e, t| {
                e[EgoField::VelLong as usize] = None;
                t.values[PartnerField::PosX as usize] = None;
            }),
            Some(Unscored::EgoSpeedMissing)
        );
        assert_eq!(
            run(&|_, t| t.values[PartnerField::PosY as usize] = stamped(1.5, T - STALE - 1)),
            Some(Unscored::InputMissing(PartnerField::PosY))
        );
        assert_eq!(
            run(&|_, t| t.values[PartnerField::Length as usize] = stamped(0.0, T)),
            Some(Unscored::BadState)
        );
        assert!(Unscored::BadState.after_ego_speed() && !Unscored::Invalid.after_ego_speed());
    }
}
