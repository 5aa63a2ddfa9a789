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
//! - `[warning]`: the output message and its signals, E2E data id;
//! - companion slot messages (`companions = "TRACK_B_*"`, fields with `companion = true`), flag
//!   expressions (`valid = "VALID and LONG_DIST < 255"`), a field of view (`[sensor] fov_deg`,
//!   `max_range`), and `[bus]`: DBC files per bus.
//!
//! Files: `file` (the TOML as written), `compiled` (the resolved map the engine reads),
//! `compile` (names resolved against the DBC), `validate` (rules across fields and signals),
//! `report` (the start-up list of where each input comes from), `bus` (DBC files bound to
//! buses), `flag_expr` (flag expressions).
mod bus;
mod compile;
mod compiled;
mod file;
pub mod flag_expr;
mod report;
mod validate;

pub use bus::{bus_label, BusDatabase, BusPart, Clash};
pub use compiled::{
    CompiledMap, Condition, EgoField, FieldOfView, FieldSlot, InputMessage, Mount, PartnerField,
    WarningSlots, EGO_FIELDS, PARTNER_FIELDS,
};
pub use file::{
    EgoMap, FlagRef, MapFile, MissingVelocity, PartnerMap, PositionKind, SensorMap, SignalRef,
    SlotList, TrackIdSpec, VelocityFrame, WarningMap, DEFAULT_MOTION_WINDOW_MS,
};
pub use validate::MAX_FLAG_BITS;

/// The project's default map (for `can-bridge/dbc/riskscore.dbc`).
pub const DEFAULT_MAP: &str = include_str!("../../maps/riskscore.toml");

/// Why a map could not be used.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    #[error("map TOML: {0}")]
    Toml(String),
    #[error("map field `{field}`: {reason}")]
    Field { field: String, reason: String },
}

pub(crate) fn field_error(field: impl Into<String>, reason: impl Into<String>) -> MapError {
    MapError::Field {
        field: field.into(),
        reason: reason.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::compile::glob_messages;
    use super::compiled::PARTNER_KEYS;
    use super::*;
    use can_codec::Database;

    #[test]
    fn project_map_compiles() {
        let (_db, map) = CompiledMap::project_default().unwrap();
        assert_eq!(map.inputs.len(), 5);
        let unused = [
            PartnerField::Range,
            PartnerField::Azimuth,
            PartnerField::RangeRate,
            PartnerField::NewTrack,
        ];
        for (i, has) in map.has_partner_field.iter().enumerate() {
            assert_eq!(
                *has,
                !unused.iter().any(|f| *f as usize == i),
                "{}",
                PARTNER_KEYS[i]
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
    fn warning_fields_are_refused_on_one_signal_or_on_shared_bits() {
        let db = Database::parse(can_codec::project::PROJECT_DBC).unwrap();
        let compile = |map: &str, db: &Database| {
            CompiledMap::compile(&MapFile::parse(map).unwrap(), db)
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        // Before: both compiled, and every warning frame carried track 0 (or the CRC as track).
        let score_as_track =
            DEFAULT_MAP.replace("track_id = \"WarnTrackId\"", "track_id = \"WarnScore\"");
        assert_eq!(
            compile(&score_as_track, &db).unwrap_err(),
            "map field `warning.score`: signal `RISK_WARNING.WarnScore` already feeds \
             `warning.track_id`; one signal feeds one field"
        );
        let track_as_crc = DEFAULT_MAP.replace("crc = \"WarnCrc\"", "crc = \"WarnTrackId\"");
        let err = compile(&track_as_crc, &db).unwrap_err();
        assert!(
            err.starts_with("map field `warning.crc`: signal `RISK_WARNING.WarnTrackId` already feeds `warning.track_id`"),
            "{err}"
        );
        // Distinct signals whose bits overlap: the level moved into the counter's nibble.
        let dbc = can_codec::project::PROJECT_DBC
            .replace("SG_ WarnLevel : 12|4@1+", "SG_ WarnLevel : 10|4@1+");
        let overlapping = Database::parse(&dbc).unwrap();
        assert_eq!(
            compile(DEFAULT_MAP, &overlapping).unwrap_err(),
            "map field `warning.counter`: signal `RISK_WARNING.WarnCounter` shares bits with \
             `RISK_WARNING.WarnLevel`, which feeds `warning.level`: each would overwrite the \
             other in the frame"
        );
        // A Motorola CRC starting at bit 0 spans bits 0 and 15-9 while the E2E code writes byte
        // 0 whole, over the track id moved into bits 1-7: refused as no whole byte. Starting at
        // bit 7 it is byte 0.
        let split =
            can_codec::project::PROJECT_DBC.replace("SG_ WarnCrc : 0|8@1+", "SG_ WarnCrc : 0|8@0+");
        assert_eq!(
            compile(DEFAULT_MAP, &Database::parse(&split).unwrap()).unwrap_err(),
            "map field `warning.crc`: the CRC must be one whole byte"
        );
        let motorola =
            can_codec::project::PROJECT_DBC.replace("SG_ WarnCrc : 0|8@1+", "SG_ WarnCrc : 7|8@0+");
        compile(DEFAULT_MAP, &Database::parse(&motorola).unwrap()).unwrap();
        compile(DEFAULT_MAP, &db).unwrap();
    }

    #[test]
    fn an_id_a_file_of_the_frames_own_bus_defines_is_that_buses_message() {
        // The radar file on can1 reuses the id of OBJECT_MOTION (0x201) for a message of its own,
        // as Toyota's powertrain and radar files share 0x224: such a frame on can1 is can1's
        // message, not the map's input logged on the wrong bus; on an unbound can2 it is.
        let project = Database::parse(can_codec::project::PROJECT_DBC).unwrap();
        let radar = Database::parse(
            "VERSION \"\"\n\nBU_: X\n\nBO_ 513 OTHER: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n",
        )
        .unwrap();
        let db = BusDatabase {
            parts: vec![
                BusPart {
                    bus: Some("can0".into()),
                    origin: "project".into(),
                    db: project.clone(),
                },
                BusPart {
                    bus: Some("can1".into()),
                    origin: "radar.dbc".into(),
                    db: radar,
                },
            ],
        };
        let map = CompiledMap::compile_on(&MapFile::parse(DEFAULT_MAP).unwrap(), &db).unwrap();
        let id = project.message_by_name("OBJECT_MOTION").unwrap().id;
        assert_eq!(map.buses, ["can0", "can1"]);
        assert!(map.defined_on(id, Some(0)));
        assert!(map.defined_on(id, Some(1)));
        assert!(!map.defined_on(id, None));
        let ego = project.message_by_name("EGO_MOTION").unwrap().id;
        assert!(!map.defined_on(ego, Some(1)));
    }

    #[test]
    fn glob_matches_whole_names_sorted_by_id() {
        let dbc = "VERSION \"\"\n\nBU_: X\n\nBO_ 258 TRACK_A_1: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n\nBO_ 257 TRACK_A_0: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n\nBO_ 259 TRACK_B_0: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n";
        let db = BusDatabase::unbound(Database::parse(dbc).unwrap(), "t.dbc");
        let names: Vec<_> = glob_messages(&db, "TRACK_A_*")
            .iter()
            .map(|(_, m)| m.name.clone())
            .collect();
        assert_eq!(names, ["TRACK_A_0", "TRACK_A_1"]);
        assert_eq!(glob_messages(&db, "TRACK_*_0").len(), 2);
        assert!(glob_messages(&db, "TRACK").is_empty());
    }
}
