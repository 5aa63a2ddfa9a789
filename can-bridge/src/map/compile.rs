//! Compiling a map file: every message and signal name resolved against the DBC files of the
//! vehicle's buses, the object layout (slots, companions or message-per-field) built, and the
//! checks of [`super::validate`] run.
use super::bus::BusDatabase;
use super::compiled::{
    CompiledMap, Condition, EgoField, FieldOfView, FieldSlot, InputMessage, Mount, PartnerField,
    WarningSlots, EGO_FIELDS, PARTNER_FIELDS,
};
use super::file::{FlagRef, MapFile, PartnerMap, SignalRef, SlotList, TrackIdSpec, WarningMap};
use super::flag_expr;
use super::validate::{check_kinematics, check_signal_use, signal_feeds_two_fields};
use super::{field_error, MapError, DEFAULT_MAP};
use can_codec::{CanId, Database, MessageSpec};
use std::collections::BTreeMap;

/// A message of the vehicle and the bus it is on (`None`: every bus).
pub(super) type BusMessage<'a> = (Option<&'a str>, &'a MessageSpec);

/// `NAME@BUS` -> (`NAME`, `Some(BUS)`): a message of one bus, where the files of two buses
/// define the name (DBC names cannot contain `@`).
fn split_bus(name: &str) -> (&str, Option<&str>) {
    match name.split_once('@') {
        Some((n, b)) => (n, Some(b)),
        None => (name, None),
    }
}

/// Whether a message on `bus` (`None`: every bus) is on the bus `want` (`None`: any).
fn on_bus(bus: Option<&str>, want: Option<&str>) -> bool {
    match (bus, want) {
        (Some(b), Some(w)) => b == w,
        _ => true,
    }
}

/// Messages whose name matches a glob pattern (`*` = any run of characters, `@BUS` for one
/// bus), sorted by id.
pub(super) fn glob_messages<'a>(db: &'a BusDatabase, pattern: &str) -> Vec<BusMessage<'a>> {
    fn matches(p: &[u8], s: &[u8]) -> bool {
        match p.split_first() {
            None => s.is_empty(),
            Some((b'*', rest)) => (0..=s.len()).any(|i| matches(rest, &s[i..])),
            Some((c, rest)) => s.first() == Some(c) && matches(rest, &s[1..]),
        }
    }
    let (pattern, want) = split_bus(pattern);
    let mut found: Vec<BusMessage<'a>> = db
        .messages()
        .filter(|(bus, m)| on_bus(*bus, want) && matches(pattern.as_bytes(), m.name.as_bytes()))
        .collect();
    found.sort_by_key(|(_, m)| m.id);
    found
}

fn unique_message<'a>(
    db: &'a BusDatabase,
    field: &str,
    name: &str,
) -> Result<BusMessage<'a>, MapError> {
    let (bare, want) = split_bus(name);
    let mut all = db
        .messages()
        .filter(|(bus, m)| m.name == bare && on_bus(*bus, want));
    let first = all
        .next()
        .ok_or_else(|| field_error(field, format!("message `{name}` is not in the DBC")))?;
    if let Some(second) = all.next() {
        return Err(field_error(
            field,
            format!(
                "message `{name}` is defined twice in the DBC files (0x{} on {} and 0x{} on {}): name its bus, `{bare}@BUS`",
                first.1.id,
                super::bus::bus_label(first.0),
                second.1.id,
                super::bus::bus_label(second.0)
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
    Ok(FieldSlot {
        field,
        signal: signal_of(msg, name, &r.signal)?,
        factor: r.factor,
        offset: r.offset,
        check_range: r.dbc_range,
        condition: condition_of(name, r, is_flag)?,
    })
}

fn signal_of(msg: &InputMessage, field: &str, signal: &str) -> Result<usize, MapError> {
    msg.spec.signal_index(signal).ok_or_else(|| {
        field_error(
            field,
            format!("signal `{signal}` is not in message `{}`", msg.spec.name),
        )
    })
}

/// A flag expression resolved against the message it is read from.
fn resolve_expression(
    msg: &InputMessage,
    name: &str,
    field: PartnerField,
    text: &str,
) -> Result<FieldSlot<PartnerField>, MapError> {
    let terms = flag_expr::parse(text).map_err(|e| field_error(name, e))?;
    let resolved = terms
        .iter()
        .map(|t| Ok((signal_of(msg, name, &t.signal)?, t.cmp)))
        .collect::<Result<Vec<_>, MapError>>()?;
    Ok(FieldSlot {
        field,
        signal: resolved[0].0,
        factor: 1.0,
        offset: 0.0,
        check_range: false,
        condition: Condition::All(resolved),
    })
}

/// Where an object field comes from in the map file.
#[derive(Clone, Copy)]
enum Source<'a> {
    Signal(&'a SignalRef),
    Expression(&'a str),
}

impl<'a> Source<'a> {
    fn of_flag(f: &'a FlagRef) -> Self {
        match f {
            FlagRef::Signal(r) => Self::Signal(r),
            FlagRef::Expression(e) => Self::Expression(e),
        }
    }

    fn resolve(
        self,
        msg: &InputMessage,
        field: PartnerField,
        is_flag: bool,
    ) -> Result<FieldSlot<PartnerField>, MapError> {
        match self {
            Self::Signal(r) => resolve(msg, field.name(), field, r, is_flag),
            Self::Expression(e) => resolve_expression(msg, field.name(), field, e),
        }
    }

    fn describe(self) -> String {
        match self {
            Self::Signal(r) => format!("signal `{}`", r.signal),
            Self::Expression(e) => format!("`{e}`"),
        }
    }
}

fn new_input(spec: &MessageSpec, bus: Option<u8>) -> InputMessage {
    InputMessage {
        spec: spec.clone(),
        ego: Vec::new(),
        partner: Vec::new(),
        track_id: None,
        slot: None,
        is_trigger: false,
        companion: false,
        bus,
        trigger_mux: None,
    }
}

/// The index of a message's bus in `buses` (`None`: unbound).
fn bus_index(buses: &[String], bus: Option<&str>) -> Option<u8> {
    bus.and_then(|b| buses.iter().position(|x| x == b))
        .map(|i| i as u8)
}

fn message_slot<'a>(
    inputs: &'a mut Vec<InputMessage>,
    db: &BusDatabase,
    field: &str,
    name: &str,
) -> Result<&'a mut InputMessage, MapError> {
    let (bus, spec) = unique_message(db, field, name)?;
    let bus = bus_index(&db.bus_names(), bus);
    if let Some(i) = inputs
        .iter()
        .position(|m| m.spec.name == spec.name && m.bus == bus)
    {
        return Ok(&mut inputs[i]);
    }
    inputs.push(new_input(spec, bus));
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
    /// Resolves every name of `map` in `db` (every message on every bus); errors name the field
    /// and what is missing.
    pub fn compile(map: &MapFile, db: &Database) -> Result<Self, MapError> {
        Self::compile_on(map, &BusDatabase::unbound(db.clone(), "DBC"))
    }

    /// Resolves every name of `map` in the DBC files of the vehicle's buses.
    pub fn compile_on(map: &MapFile, db: &BusDatabase) -> Result<Self, MapError> {
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
            (EgoField::Heading, map.ego.heading.as_ref()),
        ];
        let mut has_ego_field = [false; EGO_FIELDS];
        for (field, r) in ego_refs {
            let Some(r) = r else { continue };
            let name = field.name();
            let message = r
                .message
                .as_deref()
                .ok_or_else(|| field_error(name, "`message` is required"))?;
            if r.companion {
                return Err(field_error(name, "`companion` is for object fields"));
            }
            let msg = message_slot(&mut inputs, db, name, message)?;
            let slot = resolve(msg, name, field, r, false)?;
            ego_source[field as usize] = source(r, &msg.spec);
            msg.ego.push(slot);
            has_ego_field[field as usize] = true;
        }

        let o = &map.partner;
        let partner_refs = [
            // `valid` first: an invalid slot's other signals are not read.
            (PartnerField::Valid, flag(&o.valid), true),
            (PartnerField::NewTrack, flag(&o.new_track), true),
            (PartnerField::PosX, value(&o.pos_x), false),
            (PartnerField::PosY, value(&o.pos_y), false),
            (PartnerField::Range, value(&o.range), false),
            (PartnerField::Azimuth, value(&o.azimuth), false),
            (PartnerField::RangeRate, value(&o.range_rate), false),
            (PartnerField::VelX, value(&o.vel_x), false),
            (PartnerField::VelY, value(&o.vel_y), false),
            (PartnerField::Accel, value(&o.accel), false),
            (PartnerField::Heading, value(&o.heading), false),
            (PartnerField::HeadingValid, flag(&o.heading_valid), true),
            (PartnerField::Length, value(&o.length), false),
            (PartnerField::Width, value(&o.width), false),
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
        if s.fov_deg
            .is_some_and(|f| !(f.is_finite() && f > 0.0 && f <= 360.0))
        {
            return Err(field_error(
                "sensor.fov_deg",
                "the full opening angle must be in (0, 360] degrees",
            ));
        }
        if s.max_range.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
            return Err(field_error(
                "sensor.max_range",
                "must be a positive range in metres",
            ));
        }
        if o.motion_window_ms == 0 || o.motion_window_ms > 10_000 {
            return Err(field_error(
                "object.motion_window_ms",
                "must be between 1 and 10000 ms",
            ));
        }
        if o.accel_relative && o.accel.is_none() {
            return Err(field_error(
                "object.accel_relative",
                "needs `object.accel` (the relative acceleration)",
            ));
        }
        check_signal_use(&inputs)?;
        let buses = db.bus_names();
        let (warning_bus, warning) = compile_warning(&map.warning, db)?;
        if inputs
            .iter()
            .any(|m| m.spec.id == warning.spec.id && m.bus == bus_index(&buses, warning_bus))
        {
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
            slot_ids: o.slots.is_some() && o.track_id.is_some(),
            warning_bus: bus_index(&buses, warning_bus),
            defined: {
                let mut ids: Vec<(CanId, Option<u8>)> = db
                    .messages()
                    .map(|(bus, m)| (m.id, bus_index(&buses, bus)))
                    .collect();
                ids.sort_unstable();
                ids.dedup();
                ids
            },
            buses,
            accel_relative: o.accel_relative,
            fov: FieldOfView {
                half_angle: s.fov_deg.map(|f| f.to_radians() / 2.0),
                max_range: s.max_range,
            },
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

type PartnerRef<'a> = (PartnerField, Option<Source<'a>>, bool);

fn value(r: &Option<SignalRef>) -> Option<Source<'_>> {
    r.as_ref().map(Source::Signal)
}

fn flag(r: &Option<FlagRef>) -> Option<Source<'_>> {
    r.as_ref().map(Source::of_flag)
}

/// The messages of a slot list (a glob pattern or names), sorted as slots.
fn slot_messages<'a>(
    db: &'a BusDatabase,
    key: &str,
    list: &SlotList,
) -> Result<(Vec<BusMessage<'a>>, String), MapError> {
    let specs: Vec<BusMessage<'a>> = match list {
        SlotList::Pattern(p) => {
            let found = glob_messages(db, p);
            if found.is_empty() {
                return Err(field_error(
                    key,
                    format!("no message of the DBC matches `{p}`"),
                ));
            }
            if let Some((i, (bus, m))) = found
                .iter()
                .enumerate()
                .find(|(i, (_, m))| found[..*i].iter().any(|(_, o)| o.name == m.name))
            {
                let first = found[..i]
                    .iter()
                    .find(|(_, o)| o.name == m.name)
                    .map(|x| x.0);
                return Err(field_error(
                    key,
                    format!(
                        "`{p}` matches message `{}` twice (on {} and on {}): the files of two buses define it",
                        m.name,
                        super::bus::bus_label(first.flatten()),
                        super::bus::bus_label(*bus)
                    ),
                ));
            }
            found
        }
        SlotList::List(names) => {
            if names.is_empty() {
                return Err(field_error(key, "the list is empty"));
            }
            names
                .iter()
                .map(|n| unique_message(db, key, n))
                .collect::<Result<_, _>>()?
        }
    };
    let (first, last) = (&specs[0].1.name, &specs[specs.len() - 1].1.name);
    let names = match list {
        SlotList::Pattern(p) => format!("the {} messages `{p}` ({first} .. {last})", specs.len()),
        SlotList::List(l) => format!("the {} messages ({first} .. {last})", l.len()),
    };
    Ok((specs, names))
}

fn compile_slots(
    o: &PartnerMap,
    list: &SlotList,
    partner_refs: &[PartnerRef<'_>],
    db: &BusDatabase,
    inputs: &mut Vec<InputMessage>,
    partner_source: &mut [String; PARTNER_FIELDS],
) -> Result<usize, MapError> {
    let (specs, names) = slot_messages(db, "object.slots", list)?;
    let companions = match &o.companions {
        Some(c) => {
            let (found, companion_names) = slot_messages(db, "object.companions", c)?;
            if found.len() != specs.len() {
                return Err(field_error(
                    "object.companions",
                    format!(
                        "{companion_names} are not one per slot: {} slot messages",
                        specs.len()
                    ),
                ));
            }
            Some((found, companion_names))
        }
        None => None,
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
    let buses = db.bus_names();
    for (slot, (bus, spec)) in specs.iter().enumerate() {
        let companion = companions.as_ref().map(|(c, _)| c[slot]);
        for (b, s) in std::iter::once((*bus, *spec)).chain(companion) {
            let b = bus_index(&buses, b);
            if inputs.iter().any(|m| m.spec.name == s.name && m.bus == b) {
                return Err(field_error(
                    "object.slots",
                    format!("message `{}` already carries ego fields", s.name),
                ));
            }
        }
        let mut msg = new_input(spec, bus_index(&buses, *bus));
        msg.slot = Some(slot as u32);
        msg.is_trigger = true;
        let mut side = companion.map(|(b, s)| {
            let mut m = new_input(s, bus_index(&buses, b));
            m.slot = Some(slot as u32);
            m.companion = true;
            m
        });
        for (field, r, is_flag) in partner_refs {
            let Some(r) = r else { continue };
            let target = match r {
                Source::Signal(r) if r.message.is_some() => {
                    return Err(field_error(
                        field.name(),
                        format!("with `slots`, name only the signal (it is read from every slot message), not `message = \"{}\"`", r.message.as_deref().unwrap_or_default()),
                    ));
                }
                Source::Signal(r) if r.companion => side.as_mut().ok_or_else(|| {
                    field_error(
                        field.name(),
                        "`companion = true` needs `[object] companions` (the companion slot messages)",
                    )
                })?,
                _ => &mut msg,
            };
            let resolved = r.resolve(target, *field, *is_flag)?;
            target.partner.push(resolved);
            let from = match (r, &companions) {
                (Source::Signal(s), Some((_, c))) if s.companion => c,
                _ => &names,
            };
            partner_source[*field as usize] = format!("{} of {from}", r.describe());
        }
        if let Some(sig) = id_signal {
            msg.track_id = Some(signal_of(&msg, "object.track_id", sig)?);
        }
        inputs.push(msg);
        inputs.extend(side);
    }
    Ok(specs.len())
}

fn compile_per_message(
    o: &PartnerMap,
    partner_refs: &[PartnerRef<'_>],
    db: &BusDatabase,
    inputs: &mut Vec<InputMessage>,
    partner_source: &mut [String; PARTNER_FIELDS],
) -> Result<(), MapError> {
    if o.companions.is_some() {
        return Err(field_error(
            "object.companions",
            "only with `slots` (companion slot messages of slot messages)",
        ));
    }
    let trigger_name = o.trigger.as_deref().ok_or_else(|| {
        field_error(
            "object.trigger",
            "required: the message that completes a track update (or use `slots`)",
        )
    })?;
    for (field, r, is_flag) in partner_refs {
        let Some(r) = r else { continue };
        let name = field.name();
        // An expression is read from the trigger message (it has no `message`).
        let message = match r {
            Source::Signal(r) => {
                if r.companion {
                    return Err(field_error(name, "`companion` is only for slot maps"));
                }
                r.message
                    .as_deref()
                    .ok_or_else(|| field_error(name, "`message` is required (or use `slots`)"))?
            }
            Source::Expression(_) => trigger_name,
        };
        let msg = message_slot(inputs, db, name, message)?;
        if !msg.ego.is_empty() {
            return Err(field_error(
                name,
                format!("message `{message}` already carries ego fields"),
            ));
        }
        let slot = r.resolve(msg, *field, *is_flag)?;
        partner_source[*field as usize] = match r {
            Source::Signal(r) => source(r, &msg.spec),
            Source::Expression(_) => format!(
                "{} of message `{}` (0x{})",
                r.describe(),
                msg.spec.name,
                msg.spec.id
            ),
        };
        msg.partner.push(slot);
    }
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
        msg.track_id = Some(signal_of(msg, &name, sig)?);
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

fn compile_warning<'a>(
    w: &WarningMap,
    db: &'a BusDatabase,
) -> Result<(Option<&'a str>, WarningSlots), MapError> {
    let (bus, spec) = unique_message(db, "warning.message", &w.message)?;
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
    // The E2E code writes byte `start_bit / 8` whole, so every bit of the signal must lie in it
    // (a Motorola `0|8@0+` starts at bit 0 and runs on into the next byte).
    let whole_byte = k
        .bit_positions()
        .all(|pos| pos / 8 == u32::from(k.start_bit) / 8);
    if k.size != 8 || !whole_byte {
        return Err(field_error("warning.crc", "the CRC must be one whole byte"));
    }
    let track_id = sig("track_id", &w.track_id)?;
    let score = sig("score", &w.score)?;
    let level = sig("level", &w.level)?;
    // Each field is encoded into its own bits of the frame: two fields on one signal, or on
    // signals that share bits, overwrite each other (the CRC written into the track byte), and
    // the receiver reads garbage that still passes the E2E check.
    let fields = [
        ("track_id", track_id),
        ("score", score),
        ("level", level),
        ("counter", counter),
        ("crc", crc),
    ];
    for (i, (field, s)) in fields.iter().enumerate() {
        for (first, t) in &fields[..i] {
            let (mine, theirs) = (&spec.signals[*s], &spec.signals[*t]);
            let reason = if s == t {
                signal_feeds_two_fields(&w.message, &mine.name, &format!("warning.{first}"))
            } else if mine.overlaps(theirs) {
                format!(
                    "signal `{0}.{1}` shares bits with `{0}.{2}`, which feeds `warning.{first}`: \
                     each would overwrite the other in the frame",
                    w.message, mine.name, theirs.name
                )
            } else {
                continue;
            };
            return Err(field_error(format!("warning.{field}"), reason));
        }
    }
    Ok((
        bus,
        WarningSlots {
            spec: spec.clone(),
            track_id,
            score,
            level,
            counter_byte: usize::from(c.start_bit / 8),
            crc_byte: usize::from(k.start_bit / 8),
            data_id: w.data_id,
        },
    ))
}
