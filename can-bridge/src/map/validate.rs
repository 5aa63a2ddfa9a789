//! Map rules across fields and signals: which kinematic inputs are required, that absent
//! velocities have a rule, and that every signal feeds one field and flags are small integers.
use super::compiled::{
    Condition, EgoField, InputMessage, PartnerField, EGO_NAMES, PARTNER_FIELDS, PARTNER_KEYS,
};
use super::file::{PartnerMap, PositionKind};
use super::{field_error, MapError};

/// Which kinematic inputs the map gives, and that absent velocities have a rule.
pub(super) fn check_kinematics(
    o: &PartnerMap,
    has: &[bool; PARTNER_FIELDS],
) -> Result<(), MapError> {
    let h = |f: PartnerField| has[f as usize];
    match o.position {
        PositionKind::Cartesian => {
            for f in [PartnerField::PosX, PartnerField::PosY] {
                if !h(f) {
                    return Err(field_error(f.name(), "required for Cartesian positions"));
                }
            }
            for f in [
                PartnerField::Range,
                PartnerField::Azimuth,
                PartnerField::RangeRate,
            ] {
                if h(f) {
                    return Err(field_error(
                        f.name(),
                        "only for polar positions (position = \"polar\")",
                    ));
                }
            }
        }
        PositionKind::Polar => {
            for f in [PartnerField::Range, PartnerField::Azimuth] {
                if !h(f) {
                    return Err(field_error(f.name(), "required for polar positions"));
                }
            }
            for f in [PartnerField::PosX, PartnerField::PosY] {
                if h(f) {
                    return Err(field_error(
                        f.name(),
                        "not with polar positions (use range and azimuth)",
                    ));
                }
            }
        }
    }
    let complete = h(PartnerField::VelX) && h(PartnerField::VelY);
    if !complete && o.missing_velocity.is_none() {
        let missing = if h(PartnerField::RangeRate) {
            "the tangential velocity".to_string()
        } else {
            [PartnerField::VelX, PartnerField::VelY]
                .iter()
                .filter(|f| !h(**f))
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(" and ")
        };
        return Err(field_error(
            "object.missing_velocity",
            format!("{missing} is not on the bus: say how to fill it, `missing_velocity = \"track_motion\"` (derived from the track's positions) or `\"zero\"`"),
        ));
    }
    Ok(())
}

/// Widest signal accepted for a flag field (`valid`, `heading_valid`: 0 = no, else yes); wider
/// signals are measurements, not flags, and mapping one is a typo.
pub const MAX_FLAG_BITS: u8 = 8;

/// Why a map is refused when one signal feeds a second field (`first` feeds it already).
pub(super) fn signal_feeds_two_fields(message: &str, signal: &str, first: &str) -> String {
    format!("signal `{message}.{signal}` already feeds `{first}`; one signal feeds one field")
}

/// Refuses a signal that feeds two fields (or a field and the track id; a flag with an explicit
/// condition is exempt), and a flag field read as
/// "non-zero" from a float or from a signal wider than [`MAX_FLAG_BITS`] (a flag with an explicit
/// condition, `one_of`/`below`/`above`, may read any signal).
pub(super) fn check_signal_use(inputs: &[InputMessage]) -> Result<(), MapError> {
    let ego_name = |f: EgoField| EGO_NAMES[f as usize];
    let partner_name = |f: PartnerField| PARTNER_KEYS[f as usize];
    for msg in inputs {
        let mut uses: Vec<(usize, String)> = Vec::new();
        uses.extend(
            msg.ego
                .iter()
                .map(|s| (s.signal, ego_name(s.field).to_string())),
        );
        // A flag with an explicit condition (`valid = { signal = "LONG_DIST", below = 255 }`) may
        // read a signal that also feeds a value: radars mark empty slots with sentinel values.
        uses.extend(
            msg.partner
                .iter()
                .filter(|s| matches!(s.condition, Condition::Value | Condition::NonZero))
                .map(|s| (s.signal, partner_name(s.field).to_string())),
        );
        if let Some(t) = msg.track_id {
            uses.push((t, format!("object.track_id.{}", msg.spec.name)));
        }
        for (i, (signal, field)) in uses.iter().enumerate() {
            if let Some((_, first)) = uses[..i].iter().find(|(s, _)| s == signal) {
                return Err(MapError::Field {
                    field: field.clone(),
                    reason: signal_feeds_two_fields(
                        &msg.spec.name,
                        &msg.spec.signals[*signal].name,
                        first,
                    ),
                });
            }
        }
        for slot in &msg.partner {
            let is_flag = matches!(
                slot.field,
                PartnerField::Valid | PartnerField::HeadingValid | PartnerField::NewTrack
            );
            if !is_flag || slot.condition != Condition::NonZero {
                continue;
            }
            let s = &msg.spec.signals[slot.signal];
            let integer = matches!(
                s.kind,
                can_codec::ValueKind::Unsigned | can_codec::ValueKind::Signed
            );
            if !integer || s.size > MAX_FLAG_BITS {
                return Err(MapError::Field {
                    field: partner_name(slot.field).into(),
                    reason: format!(
                        "a flag must be an integer signal of at most {MAX_FLAG_BITS} bits; `{}.{}` is a {}-bit {:?} signal",
                        msg.spec.name, s.name, s.size, s.kind
                    ),
                });
            }
        }
    }
    Ok(())
}
