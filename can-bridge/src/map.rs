//! The map file: which DBC signal feeds each input of the scorer, compiled against a DBC into
//! message/signal indices so the hot path never looks up a name.
//!
//! Format (TOML; the project's own is `maps/riskscore.toml`, documented in docs/can-bridge.md):
//! `[ego]` and `[object]` tables of fields `{ message, signal, factor = 1, offset = 0 }` (the value
//! used is `dbc_value * factor + offset`, for unit or sign conversion), `[object].trigger` (the
//! message that completes a track update), `[object].track_id` (track-id signal per message), and
//! `[warning]` (the output message and its signals, E2E data id).
use can_codec::{CanId, Database, MessageSpec};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The project's default map (for `can-bridge/dbc/riskscore.dbc`).
pub const DEFAULT_MAP: &str = include_str!("../maps/riskscore.toml");

/// Why a map could not be used.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    #[error("map TOML: {0}")]
    Toml(String),
    #[error("map field `{field}`: {reason}")]
    Field { field: String, reason: String },
}

/// One signal reference in the map file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SignalRef {
    pub message: String,
    pub signal: String,
    #[serde(default = "one")]
    pub factor: f64,
    #[serde(default)]
    pub offset: f64,
}

fn one() -> f64 {
    1.0
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

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectMap {
    pub trigger: String,
    /// For a multiplexed trigger message: only frames with this multiplexor value trigger.
    pub trigger_mux: Option<u64>,
    pub velocity: VelocityFrame,
    pub track_id: BTreeMap<String, String>,
    pub pos_x: SignalRef,
    pub pos_y: SignalRef,
    pub vel_x: SignalRef,
    pub vel_y: SignalRef,
    pub accel: Option<SignalRef>,
    pub heading: Option<SignalRef>,
    pub heading_valid: Option<SignalRef>,
    pub valid: Option<SignalRef>,
    pub length: Option<SignalRef>,
    pub width: Option<SignalRef>,
    pub default_length: f32,
    pub default_width: f32,
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
}
pub const OBJ_FIELDS: usize = 10;

/// A resolved field: signal `signal` of the message it belongs to, then `* factor + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldSlot<F> {
    pub field: F,
    pub signal: usize,
    pub factor: f64,
    pub offset: f64,
}

impl<F> FieldSlot<F> {
    pub fn apply(&self, value: f64) -> f64 {
        if self.factor == 1.0 && self.offset == 0.0 {
            value
        } else {
            value * self.factor + self.offset
        }
    }
}

/// What a received message contributes.
#[derive(Clone, Debug)]
pub struct InputMessage {
    pub spec: MessageSpec,
    pub ego: Vec<FieldSlot<EgoField>>,
    pub object: Vec<FieldSlot<ObjField>>,
    /// Track-id signal (present when `object` is not empty).
    pub track_id: Option<usize>,
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

/// The map resolved against a DBC.
#[derive(Clone, Debug)]
pub struct CompiledMap {
    pub inputs: Vec<InputMessage>,
    pub warning: WarningSlots,
    pub velocity: VelocityFrame,
    pub ego_defaults: (f32, f32),
    pub object_defaults: (f32, f32),
    pub has_obj_field: [bool; OBJ_FIELDS],
    pub has_ego_field: [bool; EGO_FIELDS],
}

impl CompiledMap {
    /// Resolves every name of `map` in `db`; errors name the field and what is missing.
    pub fn compile(map: &MapFile, db: &Database) -> Result<Self, MapError> {
        let mut inputs: Vec<InputMessage> = Vec::new();
        fn message_slot<'a>(
            inputs: &'a mut Vec<InputMessage>,
            db: &Database,
            field: &str,
            name: &str,
        ) -> Result<&'a mut InputMessage, MapError> {
            if let Some(i) = inputs.iter().position(|m| m.spec.name == name) {
                return Ok(&mut inputs[i]);
            }
            let spec = db.message_by_name(name).ok_or_else(|| MapError::Field {
                field: field.to_string(),
                reason: format!("message `{name}` is not in the DBC"),
            })?;
            inputs.push(InputMessage {
                spec: spec.clone(),
                ego: Vec::new(),
                object: Vec::new(),
                track_id: None,
                is_trigger: false,
                trigger_mux: None,
            });
            let last = inputs.len() - 1;
            Ok(&mut inputs[last])
        }
        fn resolve(msg: &InputMessage, field: &str, r: &SignalRef) -> Result<usize, MapError> {
            if !(r.factor.is_finite() && r.factor != 0.0 && r.offset.is_finite()) {
                return Err(MapError::Field {
                    field: field.to_string(),
                    reason: "factor must be finite and non-zero, offset finite".into(),
                });
            }
            msg.spec
                .signal_index(&r.signal)
                .ok_or_else(|| MapError::Field {
                    field: field.to_string(),
                    reason: format!("signal `{}` is not in message `{}`", r.signal, r.message),
                })
        }

        let ego_refs = [
            (EgoField::VelLong, "ego.vel_long", Some(&map.ego.vel_long)),
            (EgoField::VelLat, "ego.vel_lat", map.ego.vel_lat.as_ref()),
            (EgoField::Accel, "ego.accel", map.ego.accel.as_ref()),
            (EgoField::YawRate, "ego.yaw_rate", map.ego.yaw_rate.as_ref()),
            (EgoField::Length, "ego.length", map.ego.length.as_ref()),
            (EgoField::Width, "ego.width", map.ego.width.as_ref()),
        ];
        let mut has_ego_field = [false; EGO_FIELDS];
        for (field, name, r) in ego_refs {
            let Some(r) = r else { continue };
            let msg = message_slot(&mut inputs, db, name, &r.message)?;
            let signal = resolve(msg, name, r)?;
            msg.ego.push(FieldSlot {
                field,
                signal,
                factor: r.factor,
                offset: r.offset,
            });
            has_ego_field[field as usize] = true;
        }
        let o = &map.object;
        let obj_refs = [
            (ObjField::PosX, "object.pos_x", Some(&o.pos_x)),
            (ObjField::PosY, "object.pos_y", Some(&o.pos_y)),
            (ObjField::VelX, "object.vel_x", Some(&o.vel_x)),
            (ObjField::VelY, "object.vel_y", Some(&o.vel_y)),
            (ObjField::Accel, "object.accel", o.accel.as_ref()),
            (ObjField::Heading, "object.heading", o.heading.as_ref()),
            (
                ObjField::HeadingValid,
                "object.heading_valid",
                o.heading_valid.as_ref(),
            ),
            (ObjField::Valid, "object.valid", o.valid.as_ref()),
            (ObjField::Length, "object.length", o.length.as_ref()),
            (ObjField::Width, "object.width", o.width.as_ref()),
        ];
        let mut has_obj_field = [false; OBJ_FIELDS];
        for (field, name, r) in obj_refs {
            let Some(r) = r else { continue };
            let msg = message_slot(&mut inputs, db, name, &r.message)?;
            if !msg.ego.is_empty() {
                return Err(MapError::Field {
                    field: name.to_string(),
                    reason: format!("message `{}` already carries ego fields", r.message),
                });
            }
            let signal = resolve(msg, name, r)?;
            msg.object.push(FieldSlot {
                field,
                signal,
                factor: r.factor,
                offset: r.offset,
            });
            has_obj_field[field as usize] = true;
        }
        let trigger = message_slot(&mut inputs, db, "object.trigger", &o.trigger)?;
        trigger.is_trigger = true;
        if let Some(v) = o.trigger_mux {
            if trigger.spec.multiplexor.is_none() {
                return Err(MapError::Field {
                    field: "object.trigger_mux".into(),
                    reason: format!("message `{}` is not multiplexed", o.trigger),
                });
            }
            trigger.trigger_mux = Some(v);
        }
        for msg in &mut inputs {
            if msg.object.is_empty() && !msg.is_trigger {
                continue;
            }
            let name = format!("object.track_id.{}", msg.spec.name);
            let sig = o
                .track_id
                .get(&msg.spec.name)
                .ok_or_else(|| MapError::Field {
                    field: "object.track_id".into(),
                    reason: format!("no track-id signal given for message `{}`", msg.spec.name),
                })?;
            let r = SignalRef {
                message: msg.spec.name.clone(),
                signal: sig.clone(),
                factor: 1.0,
                offset: 0.0,
            };
            msg.track_id = Some(resolve(msg, &name, &r)?);
        }
        for name in o.track_id.keys() {
            if !inputs
                .iter()
                .any(|m| &m.spec.name == name && m.track_id.is_some())
            {
                return Err(MapError::Field {
                    field: format!("object.track_id.{name}"),
                    reason: "message carries no object field".into(),
                });
            }
        }
        for (v, name) in [
            (map.ego.default_length, "ego.default_length"),
            (map.ego.default_width, "ego.default_width"),
            (o.default_length, "object.default_length"),
            (o.default_width, "object.default_width"),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(MapError::Field {
                    field: name.into(),
                    reason: "must be a positive length in metres".into(),
                });
            }
        }
        check_signal_use(&inputs)?;
        let warning = compile_warning(&map.warning, db)?;
        if inputs.iter().any(|m| m.spec.id == warning.spec.id) {
            return Err(MapError::Field {
                field: "warning.message".into(),
                reason: "the output message is also an input message".into(),
            });
        }
        Ok(Self {
            inputs,
            warning,
            velocity: o.velocity,
            ego_defaults: (map.ego.default_length, map.ego.default_width),
            object_defaults: (o.default_length, o.default_width),
            has_obj_field,
            has_ego_field,
        })
    }

    /// The project's own DBC with its default map.
    pub fn project_default() -> Result<(Database, Self), MapError> {
        let db = Database::parse(can_codec::project::PROJECT_DBC).map_err(|e| MapError::Field {
            field: "dbc".into(),
            reason: e.to_string(),
        })?;
        let map = MapFile::parse(DEFAULT_MAP)?;
        let compiled = Self::compile(&map, &db)?;
        Ok((db, compiled))
    }

    /// Ids the bridge listens to (for kernel filters).
    pub fn input_ids(&self) -> Vec<CanId> {
        self.inputs.iter().map(|m| m.spec.id).collect()
    }
}

/// Widest signal accepted for a flag field (`valid`, `heading_valid`: 0 = no, else yes); wider
/// signals are measurements, not flags, and mapping one is a typo.
pub const MAX_FLAG_BITS: u8 = 8;

/// Refuses a signal that feeds two fields (or a field and the track id), and a flag field mapped
/// to a float or to a signal wider than [`MAX_FLAG_BITS`].
fn check_signal_use(inputs: &[InputMessage]) -> Result<(), MapError> {
    fn ego_name(f: EgoField) -> &'static str {
        match f {
            EgoField::VelLong => "ego.vel_long",
            EgoField::VelLat => "ego.vel_lat",
            EgoField::Accel => "ego.accel",
            EgoField::YawRate => "ego.yaw_rate",
            EgoField::Length => "ego.length",
            EgoField::Width => "ego.width",
        }
    }
    fn obj_name(f: ObjField) -> &'static str {
        match f {
            ObjField::PosX => "object.pos_x",
            ObjField::PosY => "object.pos_y",
            ObjField::VelX => "object.vel_x",
            ObjField::VelY => "object.vel_y",
            ObjField::Accel => "object.accel",
            ObjField::Heading => "object.heading",
            ObjField::HeadingValid => "object.heading_valid",
            ObjField::Valid => "object.valid",
            ObjField::Length => "object.length",
            ObjField::Width => "object.width",
        }
    }
    for msg in inputs {
        let mut uses: Vec<(usize, String)> = Vec::new();
        uses.extend(
            msg.ego
                .iter()
                .map(|s| (s.signal, ego_name(s.field).to_string())),
        );
        uses.extend(
            msg.object
                .iter()
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
            if !matches!(slot.field, ObjField::Valid | ObjField::HeadingValid) {
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
    let spec = db
        .message_by_name(&w.message)
        .ok_or_else(|| MapError::Field {
            field: "warning.message".into(),
            reason: format!("message `{}` is not in the DBC", w.message),
        })?;
    let sig = |field: &str, name: &str| {
        spec.signal_index(name).ok_or_else(|| MapError::Field {
            field: format!("warning.{field}"),
            reason: format!("signal `{name}` is not in message `{}`", w.message),
        })
    };
    let counter = sig("counter", &w.counter)?;
    let crc = sig("crc", &w.crc)?;
    let c = &spec.signals[counter];
    if c.size != 4 || c.start_bit % 8 != 0 || c.byte_order != can_codec::ByteOrder::Intel {
        return Err(MapError::Field {
            field: "warning.counter".into(),
            reason: "the alive counter must be the low nibble of a byte (Intel, 4 bits, start bit multiple of 8)".into(),
        });
    }
    let k = &spec.signals[crc];
    if k.size != 8 || k.start_bit % 8 != 0 {
        return Err(MapError::Field {
            field: "warning.crc".into(),
            reason: "the CRC must be one whole byte".into(),
        });
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
        assert!(map.has_obj_field.iter().all(|b| *b));
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
    }
}
