//! Compiling a map file: every message and signal name resolved against the DBC, the object
//! layout (slots or message-per-field) built, and the checks of [`super::validate`] run.
use super::compiled::{
    CompiledMap, Condition, EgoField, FieldSlot, InputMessage, Mount, PartnerField, WarningSlots,
    EGO_FIELDS, PARTNER_FIELDS,
};
use super::file::{MapFile, PartnerMap, SignalRef, SlotList, TrackIdSpec, WarningMap};
use super::validate::{check_kinematics, check_signal_use};
use super::{field_error, MapError, DEFAULT_MAP};
use can_codec::{Database, MessageSpec};
use std::collections::BTreeMap;

/// Messages whose name matches a glob pattern (`*` = any run of characters), sorted by id.
pub(super) fn glob_messages<'a>(db: &'a Database, pattern: &str) -> Vec<&'a MessageSpec> {
    fn matches(p: &[u8], s: &[u8]) -> bool {
        match p.split_first() {
            None => s.is_empty(),
            Some((b'*', rest)) => (0..=s.len()).any(|i| matches(rest, &s[i..])),
            Some((c, rest)) => s.first() == Some(c) && matches(rest, &s[1..]),
        }
    }
    let mut found: Vec<&MessageSpec> = db
        .messages
        .iter()
        .filter(|m| matches(pattern.as_bytes(), m.name.as_bytes()))
        .collect();
    found.sort_by_key(|m| m.id);
    found
}

fn unique_message<'a>(
    db: &'a Database,
    field: &str,
    name: &str,
) -> Result<&'a MessageSpec, MapError> {
    let mut all = db.messages.iter().filter(|m| m.name == name);
    let first = all
        .next()
        .ok_or_else(|| field_error(field, format!("message `{name}` is not in the DBC")))?;
    if let Some(second) = all.next() {
        return Err(field_error(
            field,
            format!(
                "message `{name}` is defined twice in the DBC files (0x{} and 0x{}): rename one",
                first.id, second.id
            ),
        ));
    }
    Ok(first)
}

fn condition_of(field: &str, r: &SignalRef, is_flag: bool) -> Result<Condition, MapError> {
    let given = [r.one_of.is_some(), r.below.is_some(), r.above.is_some()]
        .iter()
        .filter(|b| **b)
        .count();
    if !is_flag {
        if given > 0 {
            return Err(field_error(
                field,
                "`one_of`/`below`/`above` are for flags (valid, heading_valid, new_track)",
            ));
        }
        return Ok(Condition::Value);
    }
    if given > 1 {
        return Err(field_error(field, "give one of `one_of`, `below`, `above`"));
    }
    Ok(if let Some(v) = &r.one_of {
        Condition::OneOf(v.clone())
    } else if let Some(b) = r.below {
        Condition::Below(b)
    } else if let Some(a) = r.above {
        Condition::Above(a)
    } else {
        Condition::NonZero
    })
}

fn resolve<F>(
    msg: &InputMessage,
    name: &str,
    field: F,
    r: &SignalRef,
    is_flag: bool,
) -> Result<FieldSlot<F>, MapError> {
    if !(r.factor.is_finite() && r.factor != 0.0 && r.offset.is_finite()) {
        return Err(field_error(
            name,
            "factor must be finite and non-zero, offset finite",
        ));
    }
    let signal = msg.spec.signal_index(&r.signal).ok_or_else(|| {
        field_error(
            name,
            format!(
                "signal `{}` is not in message `{}`",
                r.signal, msg.spec.name
            ),
        )
    })?;
    Ok(FieldSlot {
        field,
        signal,
        factor: r.factor,
        offset: r.offset,
        check_range: r.dbc_range,
        condition: condition_of(name, r, is_flag)?,
    })
}

fn new_input(spec: &MessageSpec) -> InputMessage {
    InputMessage {
        spec: spec.clone(),
        ego: Vec::new(),
        partner: Vec::new(),
        track_id: None,
        slot: None,
        is_trigger: false,
        trigger_mux: None,
    }
}

fn message_slot<'a>(
    inputs: &'a mut Vec<InputMessage>,
    db: &Database,
    field: &str,
    name: &str,
) -> Result<&'a mut InputMessage, MapError> {
    if let Some(i) = inputs.iter().position(|m| m.spec.name == name) {
        return Ok(&mut inputs[i]);
    }
    inputs.push(new_input(unique_message(db, field, name)?));
    let last = inputs.len() - 1;
    Ok(&mut inputs[last])
}

fn source(r: &SignalRef, spec: &MessageSpec) -> String {
    format!(
        "signal `{}` of message `{}` (0x{})",
        r.signal, spec.name, spec.id
    )
}

impl CompiledMap {
    /// Resolves every name of `map` in `db`; errors name the field and what is missing.
    pub fn compile(map: &MapFile, db: &Database) -> Result<Self, MapError> {
        let mut inputs: Vec<InputMessage> = Vec::new();
        let mut ego_source: [String; EGO_FIELDS] = Default::default();
        let mut partner_source: [String; PARTNER_FIELDS] = Default::default();

        let ego_refs = [
            (EgoField::VelLong, Some(&map.ego.vel_long)),
            (EgoField::VelLat, map.ego.vel_lat.as_ref()),
            (EgoField::Accel, map.ego.accel.as_ref()),
            (EgoField::YawRate, map.ego.yaw_rate.as_ref()),
            (EgoField::Length, map.ego.length.as_ref()),
            (EgoField::Width, map.ego.width.as_ref()),
        ];
        let mut has_ego_field = [false; EGO_FIELDS];
        for (field, r) in ego_refs {
            let Some(r) = r else { continue };
            let name = field.name();
            let message = r
                .message
                .as_deref()
                .ok_or_else(|| field_error(name, "`message` is required"))?;
            let msg = message_slot(&mut inputs, db, name, message)?;
            let slot = resolve(msg, name, field, r, false)?;
            ego_source[field as usize] = source(r, &msg.spec);
            msg.ego.push(slot);
            has_ego_field[field as usize] = true;
        }

        let o = &map.partner;
        let partner_refs = [
            // `valid` first: an invalid slot's other signals are not read.
            (PartnerField::Valid, o.valid.as_ref(), true),
            (PartnerField::NewTrack, o.new_track.as_ref(), true),
            (PartnerField::PosX, o.pos_x.as_ref(), false),
            (PartnerField::PosY, o.pos_y.as_ref(), false),
            (PartnerField::Range, o.range.as_ref(), false),
            (PartnerField::Azimuth, o.azimuth.as_ref(), false),
            (PartnerField::RangeRate, o.range_rate.as_ref(), false),
            (PartnerField::VelX, o.vel_x.as_ref(), false),
            (PartnerField::VelY, o.vel_y.as_ref(), false),
            (PartnerField::Accel, o.accel.as_ref(), false),
            (PartnerField::Heading, o.heading.as_ref(), false),
            (PartnerField::HeadingValid, o.heading_valid.as_ref(), true),
            (PartnerField::Length, o.length.as_ref(), false),
            (PartnerField::Width, o.width.as_ref(), false),
        ];
        let mut has_partner_field = [false; PARTNER_FIELDS];
        for (field, r, _) in &partner_refs {
            has_partner_field[*field as usize] = r.is_some();
        }
        check_kinematics(o, &has_partner_field)?;

        let slots = match &o.slots {
            Some(list) => {
                compile_slots(o, list, &partner_refs, db, &mut inputs, &mut partner_source)?
            }
            None => {
                compile_per_message(o, &partner_refs, db, &mut inputs, &mut partner_source)?;
                0
            }
        };
        for (v, name) in [
            (map.ego.default_length, "ego.default_length"),
            (map.ego.default_width, "ego.default_width"),
            (o.default_length, "object.default_length"),
            (o.default_width, "object.default_width"),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(field_error(name, "must be a positive length in metres"));
            }
        }
        let s = &map.sensor;
        if !(s.x.is_finite() && s.y.is_finite() && s.yaw_deg.is_finite()) {
            return Err(field_error("sensor", "x, y and yaw_deg must be finite"));
        }
        if o.motion_window_ms == 0 || o.motion_window_ms > 10_000 {
            return Err(field_error(
                "object.motion_window_ms",
                "must be between 1 and 10000 ms",
            ));
        }
        check_signal_use(&inputs)?;
        let warning = compile_warning(&map.warning, db)?;
        if inputs.iter().any(|m| m.spec.id == warning.spec.id) {
            return Err(field_error(
                "warning.message",
                "the output message is also an input message",
            ));
        }
        let yaw = s.yaw_deg.to_radians();
        Ok(Self {
            inputs,
            warning,
            velocity: o.velocity,
            position: o.position,
            missing_velocity: o.missing_velocity,
            motion_window_us: o.motion_window_ms * 1000,
            mount: Mount {
                x: s.x,
                y: s.y,
                cos: libm::cos(yaw),
                sin: libm::sin(yaw),
            },
            ego_defaults: (map.ego.default_length, map.ego.default_width),
            partner_defaults: (o.default_length, o.default_width),
            has_partner_field,
            has_ego_field,
            ego_source,
            partner_source,
            slots,
        })
    }

    /// The project's own DBC with its default map.
    pub fn project_default() -> Result<(Database, Self), MapError> {
        let db = Database::parse(can_codec::project::PROJECT_DBC)
            .map_err(|e| field_error("dbc", e.to_string()))?;
        let map = MapFile::parse(DEFAULT_MAP)?;
        let compiled = Self::compile(&map, &db)?;
        Ok((db, compiled))
    }
}

type PartnerRef<'a> = (PartnerField, Option<&'a SignalRef>, bool);

fn compile_slots(
    o: &PartnerMap,
    list: &SlotList,
    partner_refs: &[PartnerRef<'_>],
    db: &Database,
    inputs: &mut Vec<InputMessage>,
    partner_source: &mut [String; PARTNER_FIELDS],
) -> Result<usize, MapError> {
    let specs: Vec<&MessageSpec> = match list {
        SlotList::Pattern(p) => {
            let found = glob_messages(db, p);
            if found.is_empty() {
                return Err(field_error(
                    "object.slots",
                    format!("no message of the DBC matches `{p}`"),
                ));
            }
            found
        }
        SlotList::List(names) => {
            if names.is_empty() {
                return Err(field_error("object.slots", "the list is empty"));
            }
            names
                .iter()
                .map(|n| unique_message(db, "object.slots", n))
                .collect::<Result<_, _>>()?
        }
    };
    if o.trigger.is_some() || o.trigger_mux.is_some() {
        return Err(field_error(
            "object.trigger",
            "not with `slots`: every slot frame is a complete update of its track",
        ));
    }
    let id_signal = match &o.track_id {
        None => None,
        Some(TrackIdSpec::Signal(s)) => Some(s.as_str()),
        Some(TrackIdSpec::PerMessage(_)) => {
            return Err(field_error(
                "object.track_id",
                "with `slots`, give one signal name (`track_id = \"ObjId\"`) or leave it out (the slot number is the track id)",
            ))
        }
    };
    let names = match list {
        SlotList::Pattern(p) => format!(
            "the {} slot messages `{p}` ({} .. {})",
            specs.len(),
            specs[0].name,
            specs[specs.len() - 1].name
        ),
        SlotList::List(l) => format!(
            "the {} slot messages ({} .. {})",
            l.len(),
            l[0],
            l[l.len() - 1]
        ),
    };
    for (slot, spec) in specs.iter().enumerate() {
        if inputs.iter().any(|m| m.spec.id == spec.id) {
            return Err(field_error(
                "object.slots",
                format!("message `{}` already carries ego fields", spec.name),
            ));
        }
        let mut msg = new_input(spec);
        msg.slot = Some(slot as u32);
        msg.is_trigger = true;
        for (field, r, is_flag) in partner_refs {
            let Some(r) = r else { continue };
            if let Some(m) = &r.message {
                return Err(field_error(
                    field.name(),
                    format!("with `slots`, name only the signal (it is read from every slot message), not `message = \"{m}\"`"),
                ));
            }
            let resolved = resolve(&msg, field.name(), *field, r, *is_flag)?;
            msg.partner.push(resolved);
            partner_source[*field as usize] = format!("signal `{}` of {names}", r.signal);
        }
        if let Some(sig) = id_signal {
            msg.track_id = Some(msg.spec.signal_index(sig).ok_or_else(|| {
                field_error(
                    "object.track_id",
                    format!("signal `{sig}` is not in message `{}`", spec.name),
                )
            })?);
        }
        inputs.push(msg);
    }
    Ok(specs.len())
}

fn compile_per_message(
    o: &PartnerMap,
    partner_refs: &[PartnerRef<'_>],
    db: &Database,
    inputs: &mut Vec<InputMessage>,
    partner_source: &mut [String; PARTNER_FIELDS],
) -> Result<(), MapError> {
    for (field, r, is_flag) in partner_refs {
        let Some(r) = r else { continue };
        let name = field.name();
        let message = r
            .message
            .as_deref()
            .ok_or_else(|| field_error(name, "`message` is required (or use `slots`)"))?;
        let msg = message_slot(inputs, db, name, message)?;
        if !msg.ego.is_empty() {
            return Err(field_error(
                name,
                format!("message `{message}` already carries ego fields"),
            ));
        }
        let slot = resolve(msg, name, *field, r, *is_flag)?;
        partner_source[*field as usize] = source(r, &msg.spec);
        msg.partner.push(slot);
    }
    let trigger_name = o.trigger.as_deref().ok_or_else(|| {
        field_error(
            "object.trigger",
            "required: the message that completes a track update (or use `slots`)",
        )
    })?;
    let trigger = message_slot(inputs, db, "object.trigger", trigger_name)?;
    trigger.is_trigger = true;
    if let Some(v) = o.trigger_mux {
        if trigger.spec.multiplexor.is_none() {
            return Err(field_error(
                "object.trigger_mux",
                format!("message `{trigger_name}` is not multiplexed"),
            ));
        }
        trigger.trigger_mux = Some(v);
    }
    let empty = BTreeMap::new();
    let track_ids = match &o.track_id {
        Some(TrackIdSpec::PerMessage(t)) => t,
        Some(TrackIdSpec::Signal(_)) => {
            return Err(field_error(
                "object.track_id",
                "give the track-id signal of every object message: `track_id = { MSG = \"Sig\" }` (one name is for `slots`)",
            ))
        }
        None => &empty,
    };
    for msg in inputs.iter_mut() {
        if msg.partner.is_empty() && !msg.is_trigger {
            continue;
        }
        let name = format!("object.track_id.{}", msg.spec.name);
        let sig = track_ids.get(&msg.spec.name).ok_or_else(|| {
            field_error(
                "object.track_id",
                format!("no track-id signal given for message `{}`", msg.spec.name),
            )
        })?;
        msg.track_id = Some(msg.spec.signal_index(sig).ok_or_else(|| {
            field_error(
                &name,
                format!("signal `{sig}` is not in message `{}`", msg.spec.name),
            )
        })?);
    }
    for name in track_ids.keys() {
        if !inputs
            .iter()
            .any(|m| &m.spec.name == name && m.track_id.is_some())
        {
            return Err(field_error(
                format!("object.track_id.{name}"),
                "message carries no object field",
            ));
        }
    }
    Ok(())
}

fn compile_warning(w: &WarningMap, db: &Database) -> Result<WarningSlots, MapError> {
    let spec = unique_message(db, "warning.message", &w.message)?;
    let sig = |field: &str, name: &str| {
        spec.signal_index(name).ok_or_else(|| {
            field_error(
                format!("warning.{field}"),
                format!("signal `{name}` is not in message `{}`", w.message),
            )
        })
    };
    let counter = sig("counter", &w.counter)?;
    let crc = sig("crc", &w.crc)?;
    let c = &spec.signals[counter];
    if c.size != 4 || c.start_bit % 8 != 0 || c.byte_order != can_codec::ByteOrder::Intel {
        return Err(field_error(
            "warning.counter",
            "the alive counter must be the low nibble of a byte (Intel, 4 bits, start bit multiple of 8)",
        ));
    }
    let k = &spec.signals[crc];
    if k.size != 8 || k.start_bit % 8 != 0 {
        return Err(field_error("warning.crc", "the CRC must be one whole byte"));
    }
    Ok(WarningSlots {
        spec: spec.clone(),
        track_id: sig("track_id", &w.track_id)?,
        score: sig("score", &w.score)?,
        level: sig("level", &w.level)?,
        counter_byte: usize::from(c.start_bit / 8),
        crc_byte: usize::from(k.start_bit / 8),
        data_id: w.data_id,
    })
}
