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
pub struct PartnerMap {
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
    /// The partner's signals; the file calls the table `[object]`, the radar's word for what it tracks.
    #[serde(rename = "object")]
    pub partner: PartnerMap,
    pub warning: WarningMap,
}

impl MapFile {
    pub fn parse(text: &str) -> Result<Self, MapError> {
        toml::from_str(text).map_err(|e| MapError::Toml(e.to_string()))
    }
}
