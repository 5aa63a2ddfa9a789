//! The map resolved against a DBC: scorer fields, field slots per input message, the warning
//! message's signals and the sensor mounting, as the engine reads them on every frame.
use super::file::{MissingVelocity, PositionKind, VelocityFrame};
use super::flag_expr::Cmp;
use can_codec::{CanId, MessageSpec};

/// Ego inputs, in [`CompiledMap::ego_fields`] order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EgoField {
    VelLong = 0,
    VelLat,
    Accel,
    YawRate,
    Length,
    Width,
    Heading,
}
pub const EGO_FIELDS: usize = 7;
pub(super) const EGO_NAMES: [&str; EGO_FIELDS] = [
    "ego.vel_long",
    "ego.vel_lat",
    "ego.accel",
    "ego.yaw_rate",
    "ego.length",
    "ego.width",
    "ego.heading",
];

/// Object inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartnerField {
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
pub const PARTNER_FIELDS: usize = 14;
pub(super) const PARTNER_KEYS: [&str; PARTNER_FIELDS] = [
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

impl PartnerField {
    pub fn name(self) -> &'static str {
        PARTNER_KEYS[self as usize]
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
    /// A flag expression: every `(signal, comparison)` holds (read by the decoder, which has
    /// the other signals of the frame).
    All(Vec<(usize, Cmp)>),
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
            // Evaluated over the whole frame in the decoder; `value` is the result there.
            Condition::All(_) => value,
        }
    }
}

/// What a received message contributes.
#[derive(Clone, Debug)]
pub struct InputMessage {
    pub spec: MessageSpec,
    pub ego: Vec<FieldSlot<EgoField>>,
    /// Object fields; a `valid` field comes first (an invalid slot's other signals are not read).
    pub partner: Vec<FieldSlot<PartnerField>>,
    /// Track-id signal.
    pub track_id: Option<usize>,
    /// Slot maps: the slot number (the track id when there is no id signal).
    pub slot: Option<u32>,
    pub is_trigger: bool,
    /// A companion slot message (`[object] companions`): its fields join the track of `slot`.
    pub companion: bool,
    /// The bus (index into [`CompiledMap::buses`]) the message is bound to; `None`: every bus.
    pub bus: Option<u8>,
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
    pub partner_defaults: (f32, f32),
    pub has_partner_field: [bool; PARTNER_FIELDS],
    pub has_ego_field: [bool; EGO_FIELDS],
    /// Where each mapped input comes from, for messages ("signal `S` of message `M` (0x123)").
    pub ego_source: [String; EGO_FIELDS],
    pub partner_source: [String; PARTNER_FIELDS],
    /// Slot maps: how many slot messages.
    pub slots: usize,
    /// Slot maps with an id signal read by companions: companions follow the slot's last id.
    pub slot_ids: bool,
    /// Buses named by bound DBC files (interface names); frames on others match unbound
    /// messages only.
    pub buses: Vec<String>,
    /// The warning message's bus (`None`: unbound).
    pub warning_bus: Option<u8>,
    /// Every id a DBC file defines, with the bus it is bound to (`None`: every bus), sorted: a
    /// frame of an input message's id that a file of its own bus defines is that bus's message
    /// (Toyota's 0x224 is a powertrain message on can0 and a radar track on can1), not an input
    /// logged on the wrong bus ([`CompiledMap::defined_on`]).
    pub defined: Vec<(CanId, Option<u8>)>,
    pub fov: FieldOfView,
    /// The object's acceleration is relative to the ego's.
    pub accel_relative: bool,
}

/// Where the sensor sees: half the opening angle (rad) and the farthest range (m), in the
/// sensor frame; `None`: unlimited.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FieldOfView {
    pub half_angle: Option<f64>,
    pub max_range: Option<f64>,
}

impl FieldOfView {
    /// Whether a sensor-frame position is inside the view.
    pub fn contains(&self, (x, y): (f64, f64)) -> bool {
        let angle_ok = self.half_angle.is_none_or(|h| libm::atan2(y, x).abs() <= h);
        let range_ok = self.max_range.is_none_or(|r| libm::hypot(x, y) <= r);
        angle_ok && range_ok
    }
}

impl CompiledMap {
    /// Ids the bridge listens to (for kernel filters).
    pub fn input_ids(&self) -> Vec<CanId> {
        self.inputs.iter().map(|m| m.spec.id).collect()
    }

    /// The bus index of an interface name (`None`: not a bound bus).
    pub fn bus_of(&self, iface: &str) -> Option<u8> {
        self.buses.iter().position(|b| b == iface).map(|i| i as u8)
    }

    /// The input message a frame with `id` on `bus` is, if any.
    pub fn input_index(&self, id: CanId, bus: Option<u8>) -> Option<usize> {
        self.inputs
            .iter()
            .position(|m| m.spec.id == id && (m.bus.is_none() || m.bus == bus))
    }

    /// Whether a DBC file bound to `bus` (or to every bus) defines `id`.
    pub fn defined_on(&self, id: CanId, bus: Option<u8>) -> bool {
        let first = self.defined.partition_point(|(i, _)| *i < id);
        self.defined[first..]
            .iter()
            .take_while(|(i, _)| *i == id)
            .any(|(_, b)| b.is_none() || *b == bus)
    }
}
