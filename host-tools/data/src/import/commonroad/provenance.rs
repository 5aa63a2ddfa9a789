//! `scenarios.csv` of an imported folder: one row per event with the scenario it comes from and
//! its geometry at closest approach, so a benchmark can slice real data by geometry without
//! re-deriving it. The loader ignores the file (docs/event-format.md); a folder without it (an
//! older import) still loads, and [`closest_approach`](super::closest_approach) of an event's
//! frames gives the same geometry.
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use riskscore_output::AtomicFile;
use scorer_core::interaction::Geometry;
use scorer_core::VehicleState;

use super::pairs::SafeInteraction;
use crate::events::{open_csv, read_numbered_record, EventsError};

/// The per-event file of an imported folder (the simulator writes its own per-event file of the
/// same name with other columns).
pub const PROVENANCE_FILE: &str = "scenarios.csv";

/// Its header.
pub const PROVENANCE_COLUMNS: [&str; 8] = [
    "event_id",
    "scenario",
    "geometry",
    "closest_time",
    "min_gap",
    "min_centre_distance",
    "ego_speed",
    "partner_speed",
];

/// Streams the rows of [`PROVENANCE_FILE`] into a temporary file renamed into place together
/// with the event files.
pub struct ProvenanceWriter {
    path: PathBuf,
    rows: csv::Writer<AtomicFile>,
}

impl ProvenanceWriter {
    /// Creates the file (with its header) in the folder `dir`, which must exist.
    pub fn create(dir: &Path) -> Result<Self, EventsError> {
        let path = dir.join(PROVENANCE_FILE);
        let file = AtomicFile::create(&path).map_err(|e| io(&path, e))?;
        let mut rows = csv::Writer::from_writer(file);
        rows.write_record(PROVENANCE_COLUMNS)
            .map_err(|e| io(&path, e.into()))?;
        Ok(Self { path, rows })
    }

    /// One row for `s` from the scenario `scenario`.
    pub fn write(&mut self, scenario: &str, s: &SafeInteraction) -> Result<(), EventsError> {
        let c = &s.closest;
        let speed = |v: &VehicleState| v.vx.hypot(v.vy);
        let (ego, partner) = s
            .event
            .frames
            .get(c.frame)
            .map_or((f32::NAN, f32::NAN), |f| (speed(&f.ego), speed(&f.partner)));
        let geometry = c.geometry.map_or("", Geometry::as_str);
        self.rows
            .write_record([
                s.event.id.as_str(),
                scenario,
                geometry,
                &c.time.to_string(),
                &c.gap.to_string(),
                &s.min_centre_distance.to_string(),
                &ego.to_string(),
                &partner.to_string(),
            ])
            .map_err(|e| io(&self.path, e.into()))
    }

    /// The file, to be renamed into place with the event files
    /// ([`crate::events::EventWriter::finish_with`]).
    pub fn into_file(self) -> Result<AtomicFile, EventsError> {
        self.rows
            .into_inner()
            .map_err(|e| io(&self.path, e.into_error()))
    }
}

fn io(path: &Path, e: std::io::Error) -> EventsError {
    EventsError::Io {
        path: path.to_path_buf(),
        source: e,
    }
}

/// A row of [`PROVENANCE_FILE`] that cannot be read: file, line and column.
#[derive(Debug, thiserror::Error)]
pub enum ProvenanceError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {problem}")]
    Row {
        path: PathBuf,
        line: u64,
        problem: String,
    },
}

/// The geometry of every event listed in `dir`'s [`PROVENANCE_FILE`] (events with an empty
/// geometry are left out). `Ok(None)` when the folder has no such file, or one without a
/// `geometry` column (a simulator folder).
pub fn read_event_geometries(
    dir: &Path,
) -> Result<Option<HashMap<String, Geometry>>, ProvenanceError> {
    let path = dir.join(PROVENANCE_FILE);
    if !path.exists() {
        return Ok(None);
    }
    let row_error = |line: u64, problem: String| ProvenanceError::Row {
        path: path.clone(),
        line,
        problem,
    };
    let (mut reader, ends) = open_csv(&path).map_err(|e| match e {
        EventsError::Io { path, source } => ProvenanceError::Io { path, source },
        other => ProvenanceError::Io {
            path: path.clone(),
            source: std::io::Error::other(other.to_string()),
        },
    })?;
    let headers = reader
        .headers()
        .map_err(|e| row_error(1, e.to_string()))?
        .clone();
    let column = |name: &str| headers.iter().position(|h| h == name);
    let (Some(id_col), Some(geometry_col)) = (column("event_id"), column("geometry")) else {
        return Ok(None);
    };
    let mut out = HashMap::new();
    let mut record = csv::StringRecord::new();
    loop {
        let line = match read_numbered_record(&mut reader, &mut record, ends) {
            Ok(Some(line)) => line,
            Ok(None) => break,
            Err(e) => {
                let line = e.position().map_or(reader.position().line(), |p| p.line());
                return Err(row_error(line, e.to_string()));
            }
        };
        let (Some(id), Some(name)) = (record.get(id_col), record.get(geometry_col)) else {
            return Err(row_error(line, "missing a field".into()));
        };
        if name.is_empty() {
            continue;
        }
        let g = Geometry::from_name(name).ok_or_else(|| {
            row_error(
                line,
                format!(
                    "column `geometry`: `{name}` is not following, adjacent, crossing or oncoming"
                ),
            )
        })?;
        if out.insert(id.to_string(), g).is_some() {
            return Err(row_error(
                line,
                format!("column `event_id`: `{id}` is listed twice"),
            ));
        }
    }
    Ok(Some(out))
}
