//! Decoding one frame of a mapped message into the ego and object field values it carries.
use super::DecodeError;
use crate::map::{Condition, EgoField, InputMessage, PartnerField, EGO_FIELDS, PARTNER_FIELDS};
use can_codec::SignalError;

/// The field values of one frame, in the order of the message's field slots.
pub(super) struct Decoded {
    pub ego: [(EgoField, f64); EGO_FIELDS],
    pub n_ego: usize,
    pub partner: [(PartnerField, f64); PARTNER_FIELDS],
    pub n_partner: usize,
    pub track: Option<u32>,
}

/// Decodes `data` as a frame of `msg`; an invalid object's other signals are not read.
pub(super) fn decode_message(msg: &InputMessage, data: &[u8]) -> Result<Decoded, DecodeError> {
    let spec = &msg.spec;
    let expected = spec.size;
    let len_ok = data.len() == expected
        || (expected > 8
            && can_codec::frame::is_valid_fd_len(data.len())
            && data.len() >= expected);
    if !len_ok {
        return Err(DecodeError::WrongLength {
            len: data.len(),
            expected,
        });
    }
    let read = |signal: usize, check_range: bool| -> Result<Option<f64>, DecodeError> {
        let s = &spec.signals[signal];
        let signal_error = |cause| DecodeError::Signal {
            signal: s.name.clone(),
            cause,
        };
        match spec.value(signal, data) {
            Ok(None) => Ok(None),
            Ok(Some(v)) if !check_range && v.is_finite() => Ok(Some(v)),
            Ok(Some(v)) => s.check_range(v).map(Some).map_err(signal_error),
            Err(SignalError::NotFinite) => Err(DecodeError::NotFinite {
                signal: s.name.clone(),
            }),
            Err(e) => Err(signal_error(e)),
        }
    };
    let mut d = Decoded {
        ego: [(EgoField::VelLong, 0.0); EGO_FIELDS],
        n_ego: 0,
        partner: [(PartnerField::PosX, 0.0); PARTNER_FIELDS],
        n_partner: 0,
        track: None,
    };
    for slot in &msg.ego {
        if let Some(v) = read(slot.signal, slot.check_range)? {
            d.ego[d.n_ego] = (slot.field, slot.apply(v));
            d.n_ego += 1;
        }
    }
    let track = match (msg.track_id, msg.slot) {
        (Some(id_signal), _) => {
            let Some(id) = read(id_signal, true)? else {
                return Ok(d);
            };
            if !(id >= 0.0 && id <= f64::from(u32::MAX) && id.fract() == 0.0) {
                return Err(DecodeError::TrackId { id });
            }
            id as u32
        }
        (None, Some(slot)) => slot,
        (None, None) => return Ok(d),
    };
    d.track = Some(track);
    for slot in &msg.partner {
        let value = match &slot.condition {
            Condition::All(terms) => {
                // A flag expression: true when every term holds (a multiplexed-out signal: false).
                let mut all = true;
                for (signal, cmp) in terms {
                    all &= read(*signal, false)?.is_some_and(|v| cmp.holds(v));
                }
                Some(if all { 1.0 } else { 0.0 })
            }
            _ => read(slot.signal, slot.check_range)?,
        };
        if let Some(v) = value {
            let v = slot.apply(v);
            d.partner[d.n_partner] = (slot.field, v);
            d.n_partner += 1;
            // An invalid object's other signals are filler: not read, never a decode error.
            if slot.field == PartnerField::Valid && v == 0.0 {
                break;
            }
        }
    }
    Ok(d)
}
