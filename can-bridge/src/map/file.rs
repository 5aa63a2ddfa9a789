//! The map file as written: the TOML structure, its defaults and parsing.
use super::MapError;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Default window over which a derived velocity is measured (`motion_window_ms`).
pub const DEFAULT_MOTION_WINDOW_MS: u64 = 200;

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
    /// Slot maps: read from the companion slot message (`[object] companions`) of the slot.
    #[serde(default)]
    pub companion: bool,
}

/// A flag field: one signal (with an optional condition) or an expression over several signals
/// of one message (`"VALID and LONG_DIST < 255"`, see [`super::flag_expr`]).
#[derive(Clone, Debug, PartialEq)]
pub enum FlagRef {
    Expression(String),
    Signal(SignalRef),
}

// By hand rather than `untagged`, so a typo in a flag's table is named as in every other field.
impl<'de> Deserialize<'de> for FlagRef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = FlagRef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a signal table `{ signal = \"S\", ... }` or an expression string")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<FlagRef, E> {
                Ok(FlagRef::Expression(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<FlagRef, A::Error> {
                SignalRef::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(FlagRef::Signal)
            }
        }
        d.deserialize_any(Visitor)
    }
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
    /// The ego's heading (rad, counter-clockwise, any zero): its change over the motion window
    /// is the yaw rate when `yaw_rate` is not on the bus.
    pub heading: Option<SignalRef>,
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
pub struct PartnerMap {
    /// Slot map: each of these messages is one track slot.
    pub slots: Option<SlotList>,
    /// Slot map: companion messages, one per slot in the same order (`TRACK_B_n` of
    /// `TRACK_A_n`); fields with `companion = true` are read from them.
    pub companions: Option<SlotList>,
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
    /// `accel` is relative to the ego's acceleration (the ego's `accel` is added).
    #[serde(default)]
    pub accel_relative: bool,
    pub heading: Option<SignalRef>,
    pub heading_valid: Option<FlagRef>,
    pub valid: Option<FlagRef>,
    pub new_track: Option<FlagRef>,
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
    /// Field of view: full opening angle (deg) centred on the sensor's x axis; a track outside
    /// it is not scored and its track is dropped.
    pub fov_deg: Option<f64>,
    /// Farthest range (m from the sensor) the sensor reports; beyond it as outside the view.
    pub max_range: Option<f64>,
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
    /// The partner's signals; the file calls the table `[object]`, the radar's word for what it tracks.
    #[serde(rename = "object")]
    pub partner: PartnerMap,
    pub warning: WarningMap,
    /// DBC files per bus (interface name -> files, paths relative to the map file), used when
    /// no `--dbc` is given. A name no interface can have (longer than IFNAMSIZ - 1 bytes) is
    /// refused when the map is parsed, at its line, as `--dbc BUS=FILE` refuses it.
    #[serde(default, deserialize_with = "bus_table")]
    pub bus: BTreeMap<String, Vec<String>>,
}

/// A `[bus]` key: an interface name ([`can_codec::check_iface_name`]).
#[derive(PartialEq, Eq, PartialOrd, Ord)]
struct BusName(String);

impl<'de> Deserialize<'de> for BusName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        can_codec::check_iface_name(&name).map_err(|e| {
            serde::de::Error::custom(format!("[bus]: a bus is an interface name, and {e}"))
        })?;
        Ok(BusName(name))
    }
}

/// The `[bus]` table, every key checked as it is read (so the error carries the key's line).
fn bus_table<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<BTreeMap<String, Vec<String>>, D::Error> {
    let table = BTreeMap::<BusName, Vec<String>>::deserialize(d)?;
    Ok(table.into_iter().map(|(k, v)| (k.0, v)).collect())
}

impl MapFile {
    pub fn parse(text: &str) -> Result<Self, MapError> {
        toml::from_str(text).map_err(|e| MapError::Toml(e.to_string()))
    }
}
