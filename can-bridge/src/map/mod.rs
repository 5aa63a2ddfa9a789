//! The map file: which DBC signal feeds each input of the scorer, compiled against the bus's DBC
//! files into message/signal indices so the hot path never looks up a name.
//!
//! Format (TOML; the project's own is `maps/riskscore.toml`, real radars in `maps/*.toml`,
//! reference in docs/can-bridge.md, "Bring your own vehicle"):
//! - `[ego]` and `[object]` fields `{ message, signal, factor = 1, offset = 0, dbc_range = true }`
//!   (value used = `dbc_value * factor + offset`, for unit or sign conversion);
//! - objects either per message with a track-id signal (`track_id = { MSG = "Sig" }`, `trigger`),
//!   or as **slots** (`slots = "TRACK_*"` or a list): each slot message is one track, its slot
//!   number (or an id signal, `track_id = "Sig"`) the track id, and every slot frame an update;
//! - Cartesian (`pos_x`/`pos_y`) or polar (`position = "polar"`: `range`/`azimuth`,
//!   `range_rate`) positions, with velocities that are absent derived from the track's motion or
//!   taken as zero (`missing_velocity`);
//! - `valid` / `new_track` flags with conditions (`one_of`, `below`, `above`);
//! - `[sensor]`: where the sensor sits on the ego (`x`, `y`, `yaw_deg`);
//! - `[warning]`: the output message and its signals, E2E data id.
use can_codec::{CanId, Database, MessageSpec};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The project's default map (for `can-bridge/dbc/riskscore.dbc`).
pub const DEFAULT_MAP: &str = include_str!("../../maps/riskscore.toml");

/// Default window over which a derived velocity is measured (`motion_window_ms`).
pub const DEFAULT_MOTION_WINDOW_MS: u64 = 200;

/// Why a map could not be used.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    #[error("map TOML: {0}")]
    Toml(String),
    #[error("map field `{field}`: {reason}")]
    Field { field: String, reason: String },
}

fn field_error(field: impl Into<String>, reason: impl Into<String>) -> MapError {
    MapError::Field {
        field: field.into(),
        reason: reason.into(),
    }
}

/// One signal reference in the map file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SignalRef {
    /// The message; omitted for object fields of a slot map (read from every slot message).
    pub message: Option<String>,
    pub signal: String,
    #[serde(default = "one")]
    pub factor: f64,
    #[serde(default)]
    pub offset: f64,
    /// `false`: do not enforce the DBC's `[min|max]` for this signal (for DBCs whose declared
    /// ranges are wrong, e.g. a signed signal declared `[0|63.5]`).
    #[serde(default = "yes")]
    pub dbc_range: bool,
    /// Flags only (`valid`, `heading_valid`, `new_track`): true when the value is one of these.
    pub one_of: Option<Vec<f64>>,
    /// Flags only: true when the value is below this.
    pub below: Option<f64>,
    /// Flags only: true when the value is above this.
    pub above: Option<f64>,
}

fn one() -> f64 {
    1.0
}

fn yes() -> bool {
    true
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EgoMap {
    pub vel_long: SignalRef,
    pub vel_lat: Option<SignalRef>,
    pub accel: Option<SignalRef>,
    pub yaw_rate: Option<SignalRef>,
    pub length: Option<SignalRef>,
    pub width: Option<SignalRef>,
    pub default_length: f32,
    pub default_width: f32,
}

/// How object velocities are reported.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum VelocityFrame {
    /// Relative to the ego velocity (most radars).
    Relative,
    /// Over ground, in ego-frame axes.
    Absolute,
}

/// How object positions are reported.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum PositionKind {
    /// `pos_x` forward, `pos_y` left.
    #[default]
    Cartesian,
    /// `range` and `azimuth` (rad, counter-clockwise from the sensor's x axis).
    Polar,
}

/// What to use for velocity components the sensor does not send.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MissingVelocity {
    /// The change of the track's position over `motion_window_ms` (relative velocity).
    TrackMotion,
    /// Zero.
    Zero,
}

/// Slot messages: a glob pattern (`*` matches any run of characters) or an explicit list.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum SlotList {
    Pattern(String),
    List(Vec<String>),
}

/// The track-id signal: one per message (message-per-field maps) or one name (slot maps).
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum TrackIdSpec {
    Signal(String),
    PerMessage(BTreeMap<String, String>),
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectMap {
    /// Slot map: each of these messages is one track slot.
    pub slots: Option<SlotList>,
    /// The message that completes a track update (message-per-field maps only).
    pub trigger: Option<String>,
    /// For a multiplexed trigger message: only frames with this multiplexor value trigger.
    pub trigger_mux: Option<u64>,
    pub velocity: VelocityFrame,
    #[serde(default)]
    pub position: PositionKind,
    pub track_id: Option<TrackIdSpec>,
    pub pos_x: Option<SignalRef>,
    pub pos_y: Option<SignalRef>,
    pub range: Option<SignalRef>,
    pub azimuth: Option<SignalRef>,
    pub range_rate: Option<SignalRef>,
    pub vel_x: Option<SignalRef>,
    pub vel_y: Option<SignalRef>,
    pub missing_velocity: Option<MissingVelocity>,
    #[serde(default = "default_window")]
    pub motion_window_ms: u64,
    pub accel: Option<SignalRef>,
    pub heading: Option<SignalRef>,
    pub heading_valid: Option<SignalRef>,
    pub valid: Option<SignalRef>,
    pub new_track: Option<SignalRef>,
    pub length: Option<SignalRef>,
    pub width: Option<SignalRef>,
    pub default_length: f32,
    pub default_width: f32,
}

fn default_window() -> u64 {
    DEFAULT_MOTION_WINDOW_MS
}

/// Where the sensor sits in the ego frame (x forward from the ego reference point, the centre
/// of the ego box; y left; yaw counter-clockwise). Object positions and velocities are rotated by
/// `yaw_deg`, then positions shifted by `(x, y)`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SensorMap {
    #[serde(default)]
    pub x: f64,
    #[serde(default)]
    pub y: f64,
    #[serde(default)]
    pub yaw_deg: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarningMap {
    pub message: String,
    pub track_id: String,
    pub score: String,
    pub level: String,
    pub counter: String,
    pub crc: String,
    pub data_id: u16,
}

/// The map file as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapFile {
    #[serde(default)]
    pub sensor: SensorMap,
    pub ego: EgoMap,
    pub object: ObjectMap,
    pub warning: WarningMap,
}

impl MapFile {
    pub fn parse(text: &str) -> Result<Self, MapError> {
        toml::from_str(text).map_err(|e| MapError::Toml(e.to_string()))
    }
}

/// Ego inputs, in [`CompiledMap::ego_fields`] order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EgoField {
    VelLong = 0,
    VelLat,
    Accel,
    YawRate,
    Length,
    Width,
}
pub const EGO_FIELDS: usize = 6;
const EGO_NAMES: [&str; EGO_FIELDS] = [
    "ego.vel_long",
    "ego.vel_lat",
    "ego.accel",
    "ego.yaw_rate",
    "ego.length",
    "ego.width",
];

/// Object inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjField {
    PosX = 0,
    PosY,
    VelX,
    VelY,
    Accel,
    Heading,
    HeadingValid,
    Valid,
    Length,
    Width,
    Range,
    Azimuth,
    RangeRate,
    NewTrack,
}
pub const OBJ_FIELDS: usize = 14;
const OBJ_NAMES: [&str; OBJ_FIELDS] = [
    "object.pos_x",
    "object.pos_y",
    "object.vel_x",
    "object.vel_y",
    "object.accel",
    "object.heading",
    "object.heading_valid",
    "object.valid",
    "object.length",
    "object.width",
    "object.range",
    "object.azimuth",
    "object.range_rate",
    "object.new_track",
];

impl EgoField {
    pub fn name(self) -> &'static str {
        EGO_NAMES[self as usize]
    }
}

impl ObjField {
    pub fn name(self) -> &'static str {
        OBJ_NAMES[self as usize]
    }
}

/// A flag's condition on the DBC value (before `factor`/`offset`).
#[derive(Clone, Debug, PartialEq)]
pub enum Condition {
    /// Not a flag: the value is used as is.
    Value,
    NonZero,
    OneOf(Vec<f64>),
    Below(f64),
    Above(f64),
}

/// A resolved field: signal `signal` of the message it belongs to, then `* factor + offset`
/// (values) or the condition (flags: 1.0 true, 0.0 false).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldSlot<F> {
    pub field: F,
    pub signal: usize,
    pub factor: f64,
    pub offset: f64,
    /// Enforce the DBC's `[min|max]`.
    pub check_range: bool,
    pub condition: Condition,
}

impl<F> FieldSlot<F> {
    pub fn apply(&self, value: f64) -> f64 {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        match &self.condition {
            Condition::Value if self.factor == 1.0 && self.offset == 0.0 => value,
            Condition::Value => value * self.factor + self.offset,
            Condition::NonZero => flag(value != 0.0),
            Condition::OneOf(v) => flag(v.contains(&value)),
            Condition::Below(b) => flag(value < *b),
            Condition::Above(a) => flag(value > *a),
        }
    }
}

/// What a received message contributes.
#[derive(Clone, Debug)]
pub struct InputMessage {
    pub spec: MessageSpec,
    pub ego: Vec<FieldSlot<EgoField>>,
    /// Object fields; a `valid` field comes first (an invalid slot's other signals are not read).
    pub object: Vec<FieldSlot<ObjField>>,
    /// Track-id signal.
    pub track_id: Option<usize>,
    /// Slot maps: the slot number (the track id when there is no id signal).
    pub slot: Option<u32>,
    pub is_trigger: bool,
    /// Only frames whose multiplexor has this raw value trigger (multiplexed trigger messages).
    pub trigger_mux: Option<u64>,
}

/// Signal indices of the output message.
#[derive(Clone, Debug)]
pub struct WarningSlots {
    pub spec: MessageSpec,
    pub track_id: usize,
    pub score: usize,
    pub level: usize,
    pub counter_byte: usize,
    pub crc_byte: usize,
    pub data_id: u16,
}

/// The sensor mounting, ready to apply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mount {
    pub x: f64,
    pub y: f64,
    pub cos: f64,
    pub sin: f64,
}

impl Mount {
    /// Rotates a sensor-frame vector into the ego frame.
    pub fn rotate(&self, (x, y): (f64, f64)) -> (f64, f64) {
        (self.cos * x - self.sin * y, self.sin * x + self.cos * y)
    }

    /// Rotates an ego-frame vector into the sensor frame.
    pub fn unrotate(&self, (x, y): (f64, f64)) -> (f64, f64) {
        (self.cos * x + self.sin * y, -self.sin * x + self.cos * y)
    }

    /// A sensor-frame position in the ego frame.
    pub fn place(&self, p: (f64, f64)) -> (f64, f64) {
        let (x, y) = self.rotate(p);
        (x + self.x, y + self.y)
    }
}

/// The map resolved against a DBC.
#[derive(Clone, Debug)]
pub struct CompiledMap {
    pub inputs: Vec<InputMessage>,
    pub warning: WarningSlots,
    pub velocity: VelocityFrame,
    pub position: PositionKind,
    pub missing_velocity: Option<MissingVelocity>,
    pub motion_window_us: u64,
    pub mount: Mount,
    pub ego_defaults: (f32, f32),
    pub object_defaults: (f32, f32),
    pub has_obj_field: [bool; OBJ_FIELDS],
    pub has_ego_field: [bool; EGO_FIELDS],
    /// Where each mapped input comes from, for messages ("signal `S` of message `M` (0x123)").
    pub ego_source: [String; EGO_FIELDS],
    pub obj_source: [String; OBJ_FIELDS],
    /// Slot maps: how many slot messages.
    pub slots: usize,
}

/// Messages whose name matches a glob pattern (`*` = any run of characters), sorted by id.
fn glob_messages<'a>(db: &'a Database, pattern: &str) -> Vec<&'a MessageSpec> {
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
        object: Vec::new(),
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
        let mut obj_source: [String; OBJ_FIELDS] = Default::default();

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

        let o = &map.object;
        let obj_refs = [
            // `valid` first: an invalid slot's other signals are not read.
            (ObjField::Valid, o.valid.as_ref(), true),
            (ObjField::NewTrack, o.new_track.as_ref(), true),
            (ObjField::PosX, o.pos_x.as_ref(), false),
            (ObjField::PosY, o.pos_y.as_ref(), false),
            (ObjField::Range, o.range.as_ref(), false),
            (ObjField::Azimuth, o.azimuth.as_ref(), false),
            (ObjField::RangeRate, o.range_rate.as_ref(), false),
            (ObjField::VelX, o.vel_x.as_ref(), false),
            (ObjField::VelY, o.vel_y.as_ref(), false),
            (ObjField::Accel, o.accel.as_ref(), false),
            (ObjField::Heading, o.heading.as_ref(), false),
            (ObjField::HeadingValid, o.heading_valid.as_ref(), true),
            (ObjField::Length, o.length.as_ref(), false),
            (ObjField::Width, o.width.as_ref(), false),
        ];
        let mut has_obj_field = [false; OBJ_FIELDS];
        for (field, r, _) in &obj_refs {
            has_obj_field[*field as usize] = r.is_some();
        }
        check_kinematics(o, &has_obj_field)?;

        let slots = match &o.slots {
            Some(list) => compile_slots(o, list, &obj_refs, db, &mut inputs, &mut obj_source)?,
            None => {
                compile_per_message(o, &obj_refs, db, &mut inputs, &mut obj_source)?;
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
            object_defaults: (o.default_length, o.default_width),
            has_obj_field,
            has_ego_field,
            ego_source,
            obj_source,
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

    /// Ids the bridge listens to (for kernel filters).
    pub fn input_ids(&self) -> Vec<CanId> {
        self.inputs.iter().map(|m| m.spec.id).collect()
    }

    /// One line per scorer input: where it comes from, or that it is derived or defaulted.
    /// Printed at start-up so a vehicle engineer sees what the bridge assumes.
    pub fn input_report(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let has = |f: ObjField| self.has_obj_field[f as usize];
        let src = |f: ObjField| self.obj_source[f as usize].clone();
        for (i, name) in EGO_NAMES.iter().enumerate() {
            let line = if self.has_ego_field[i] {
                format!("{name} <- {}", self.ego_source[i])
            } else {
                match i {
                    1 => format!("{name}: DEFAULT 0 m/s (not mapped)"),
                    2 => format!("{name}: DEFAULT 0 m/s^2 (not mapped)"),
                    3 => format!("{name}: not mapped (not used by the scorer)"),
                    4 => format!("{name}: DEFAULT {} m (not mapped)", self.ego_defaults.0),
                    _ => format!("{name}: DEFAULT {} m (not mapped)", self.ego_defaults.1),
                }
            };
            lines.push(line);
        }
        let m = self.mount;
        if m != (Mount {
            x: 0.0,
            y: 0.0,
            cos: 1.0,
            sin: 0.0,
        }) {
            lines.push(format!(
                "sensor mounted at x {} m, y {} m, yaw {:.3} deg from the ego reference point",
                m.x,
                m.y,
                libm::atan2(m.sin, m.cos).to_degrees()
            ));
        }
        if self.slots > 0 {
            lines.push(format!(
                "objects: {} slot messages, one track per slot",
                self.slots
            ));
        }
        match self.position {
            PositionKind::Cartesian => {
                lines.push(format!("object.pos_x <- {}", src(ObjField::PosX)));
                lines.push(format!("object.pos_y <- {}", src(ObjField::PosY)));
            }
            PositionKind::Polar => {
                lines.push(format!("object.range <- {}", src(ObjField::Range)));
                lines.push(format!("object.azimuth <- {}", src(ObjField::Azimuth)));
            }
        }
        let derived = match self.missing_velocity {
            Some(MissingVelocity::TrackMotion) => format!(
                "DERIVED from the track's motion over {} ms (a new track is scored once it has moved that long)",
                self.motion_window_us / 1000
            ),
            _ => "DEFAULT 0 m/s".to_string(),
        };
        if has(ObjField::RangeRate) {
            lines.push(format!(
                "object radial velocity <- {}",
                src(ObjField::RangeRate)
            ));
            if !(has(ObjField::VelX) && has(ObjField::VelY)) {
                lines.push(format!("object tangential velocity: {derived}"));
            }
        }
        for f in [ObjField::VelX, ObjField::VelY] {
            if has(f) {
                lines.push(format!("{} <- {}", f.name(), src(f)));
            } else if !has(ObjField::RangeRate) {
                lines.push(format!("{}: {derived}", f.name()));
            }
        }
        lines.push(format!(
            "object velocities are {}",
            match self.velocity {
                VelocityFrame::Relative => "relative to the ego (ego velocity added)",
                VelocityFrame::Absolute => "over ground",
            }
        ));
        lines.push(if has(ObjField::Heading) {
            format!("object.heading <- {}", src(ObjField::Heading))
        } else {
            format!(
                "object.heading: DERIVED from the partner's velocity over ground (when faster than {} m/s), else its last heading, else +x",
                crate::engine::HEADING_FROM_VELOCITY_MIN_SPEED
            )
        });
        lines.push(if has(ObjField::Accel) {
            format!("object.accel <- {}", src(ObjField::Accel))
        } else {
            "object.accel: DEFAULT 0 m/s^2".to_string()
        });
        for (f, d) in [
            (ObjField::Length, self.object_defaults.0),
            (ObjField::Width, self.object_defaults.1),
        ] {
            lines.push(if has(f) {
                format!("{} <- {} (default {d} m until received)", f.name(), src(f))
            } else {
                format!("{}: DEFAULT {d} m (a car box)", f.name())
            });
        }
        lines.push(if has(ObjField::Valid) {
            format!("object.valid <- {}", src(ObjField::Valid))
        } else {
            "object.valid: not mapped (every object is valid)".to_string()
        });
        if has(ObjField::NewTrack) {
            lines.push(format!(
                "object.new_track <- {} (a new object in a slot starts a fresh track)",
                src(ObjField::NewTrack)
            ));
        }
        lines
    }
}

/// Which kinematic inputs the map gives, and that absent velocities have a rule.
fn check_kinematics(o: &ObjectMap, has: &[bool; OBJ_FIELDS]) -> Result<(), MapError> {
    let h = |f: ObjField| has[f as usize];
    match o.position {
        PositionKind::Cartesian => {
            for f in [ObjField::PosX, ObjField::PosY] {
                if !h(f) {
                    return Err(field_error(f.name(), "required for Cartesian positions"));
                }
            }
            for f in [ObjField::Range, ObjField::Azimuth, ObjField::RangeRate] {
                if h(f) {
                    return Err(field_error(
                        f.name(),
                        "only for polar positions (position = \"polar\")",
                    ));
                }
            }
        }
        PositionKind::Polar => {
            for f in [ObjField::Range, ObjField::Azimuth] {
                if !h(f) {
                    return Err(field_error(f.name(), "required for polar positions"));
                }
            }
            for f in [ObjField::PosX, ObjField::PosY] {
                if h(f) {
                    return Err(field_error(
                        f.name(),
                        "not with polar positions (use range and azimuth)",
                    ));
                }
            }
        }
    }
    let complete = h(ObjField::VelX) && h(ObjField::VelY);
    if !complete && o.missing_velocity.is_none() {
        let missing = if h(ObjField::RangeRate) {
            "the tangential velocity".to_string()
        } else {
            [ObjField::VelX, ObjField::VelY]
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

type ObjRef<'a> = (ObjField, Option<&'a SignalRef>, bool);

fn compile_slots(
    o: &ObjectMap,
    list: &SlotList,
    obj_refs: &[ObjRef<'_>],
    db: &Database,
    inputs: &mut Vec<InputMessage>,
    obj_source: &mut [String; OBJ_FIELDS],
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
        for (field, r, is_flag) in obj_refs {
            let Some(r) = r else { continue };
            if let Some(m) = &r.message {
                return Err(field_error(
                    field.name(),
                    format!("with `slots`, name only the signal (it is read from every slot message), not `message = \"{m}\"`"),
                ));
            }
            let resolved = resolve(&msg, field.name(), *field, r, *is_flag)?;
            msg.object.push(resolved);
            obj_source[*field as usize] = format!("signal `{}` of {names}", r.signal);
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
    o: &ObjectMap,
    obj_refs: &[ObjRef<'_>],
    db: &Database,
    inputs: &mut Vec<InputMessage>,
    obj_source: &mut [String; OBJ_FIELDS],
) -> Result<(), MapError> {
    for (field, r, is_flag) in obj_refs {
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
        obj_source[*field as usize] = source(r, &msg.spec);
        msg.object.push(slot);
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
        if msg.object.is_empty() && !msg.is_trigger {
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

/// Widest signal accepted for a flag field (`valid`, `heading_valid`: 0 = no, else yes); wider
/// signals are measurements, not flags, and mapping one is a typo.
pub const MAX_FLAG_BITS: u8 = 8;

/// Refuses a signal that feeds two fields (or a field and the track id; a flag with an explicit
/// condition is exempt), and a flag field read as
/// "non-zero" from a float or from a signal wider than [`MAX_FLAG_BITS`] (a flag with an explicit
/// condition, `one_of`/`below`/`above`, may read any signal).
fn check_signal_use(inputs: &[InputMessage]) -> Result<(), MapError> {
    let ego_name = |f: EgoField| EGO_NAMES[f as usize];
    let obj_name = |f: ObjField| OBJ_NAMES[f as usize];
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
            msg.object
                .iter()
                .filter(|s| matches!(s.condition, Condition::Value | Condition::NonZero))
                .map(|s| (s.signal, obj_name(s.field).to_string())),
        );
        if let Some(t) = msg.track_id {
            uses.push((t, format!("object.track_id.{}", msg.spec.name)));
        }
        for (i, (signal, field)) in uses.iter().enumerate() {
            if let Some((_, first)) = uses[..i].iter().find(|(s, _)| s == signal) {
                return Err(MapError::Field {
                    field: field.clone(),
                    reason: format!(
                        "signal `{}.{}` already feeds `{first}`; one signal feeds one field",
                        msg.spec.name, msg.spec.signals[*signal].name
                    ),
                });
            }
        }
        for slot in &msg.object {
            let is_flag = matches!(
                slot.field,
                ObjField::Valid | ObjField::HeadingValid | ObjField::NewTrack
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
                    field: obj_name(slot.field).into(),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_map_compiles() {
        let (_db, map) = CompiledMap::project_default().unwrap();
        assert_eq!(map.inputs.len(), 5);
        let unused = [
            ObjField::Range,
            ObjField::Azimuth,
            ObjField::RangeRate,
            ObjField::NewTrack,
        ];
        for (i, has) in map.has_obj_field.iter().enumerate() {
            assert_eq!(
                *has,
                !unused.iter().any(|f| *f as usize == i),
                "{}",
                OBJ_NAMES[i]
            );
        }
        assert_eq!(map.warning.crc_byte, 0);
        assert_eq!(map.warning.counter_byte, 1);
        let trigger: Vec<_> = map.inputs.iter().filter(|m| m.is_trigger).collect();
        assert_eq!(trigger.len(), 1);
        assert_eq!(trigger[0].spec.name, "OBJECT_MOTION");
    }

    #[test]
    fn map_errors_name_the_field() {
        let db = Database::parse(can_codec::project::PROJECT_DBC).unwrap();
        let bad = DEFAULT_MAP.replace("\"ObjPosY\"", "\"ObjPosZ\"");
        let err = CompiledMap::compile(&MapFile::parse(&bad).unwrap(), &db).unwrap_err();
        assert!(err.to_string().contains("object.pos_y"), "{err}");
        let bad = DEFAULT_MAP.replace("trigger = \"OBJECT_MOTION\"", "trigger = \"NOPE\"");
        let err = CompiledMap::compile(&MapFile::parse(&bad).unwrap(), &db).unwrap_err();
        assert!(err.to_string().contains("object.trigger"), "{err}");
        let bad = DEFAULT_MAP.replace("velocity = \"relative\"", "velocity = \"sideways\"");
        assert!(MapFile::parse(&bad).is_err());
        let bad = DEFAULT_MAP.replace("[warning]", "[warning]\ntypo = 1");
        assert!(MapFile::parse(&bad)
            .unwrap_err()
            .to_string()
            .contains("typo"));
        // A missing velocity needs a rule.
        let bad = DEFAULT_MAP.replace(
            "vel_y = { message = \"OBJECT_MOTION\", signal = \"ObjVelRelY\" }",
            "",
        );
        let err = CompiledMap::compile(&MapFile::parse(&bad).unwrap(), &db).unwrap_err();
        assert!(
            err.to_string().contains("missing_velocity")
                && err.to_string().contains("object.vel_y"),
            "{err}"
        );
        // Conditions only on flags.
        let bad = DEFAULT_MAP.replace(
            "signal = \"ObjPosX\" }",
            "signal = \"ObjPosX\", below = 3.0 }",
        );
        let err = CompiledMap::compile(&MapFile::parse(&bad).unwrap(), &db).unwrap_err();
        assert!(err.to_string().contains("object.pos_x"), "{err}");
    }

    #[test]
    fn glob_matches_whole_names_sorted_by_id() {
        let dbc = "VERSION \"\"\n\nBU_: X\n\nBO_ 258 TRACK_A_1: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n\nBO_ 257 TRACK_A_0: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n\nBO_ 259 TRACK_B_0: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n";
        let db = Database::parse(dbc).unwrap();
        let names: Vec<_> = glob_messages(&db, "TRACK_A_*")
            .iter()
            .map(|m| m.name.clone())
            .collect();
        assert_eq!(names, ["TRACK_A_0", "TRACK_A_1"]);
        assert_eq!(glob_messages(&db, "TRACK_*_0").len(), 2);
        assert!(glob_messages(&db, "TRACK").is_empty());
    }
}
