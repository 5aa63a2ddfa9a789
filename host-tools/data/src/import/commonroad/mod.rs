//! Recorded CommonRoad scenarios (XML) to an event folder of real safe interactions.
//!
//! - [`xml`]: reading a scenario file into the tracks of its road users ([`read_scenario`]).
//! - [`pairs`]: which pairs interact, by geometry, and the safe sequences their interactions
//!   yield ([`safe_interactions`], [`InteractionRules`], [`closest_approach`]).
//! - [`smoothing`]: acceleration from a smoothed speed, for video-tracked recordings.
//! - [`repeats`]: moments an earlier file of the same import already holds (overlapping files).
//! - [`provenance`]: the per-event `scenarios.csv` (scenario, geometry at closest approach).
//! - here: importing files and folders into one event folder ([`import_to_dir`]).
//!
//! Rules, conversions and limitations: docs/real-data.md.
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::events::{EventWriter, EventsError};
use provenance::ProvenanceWriter;
use repeats::EarlierTracks;

mod derivative;
pub mod pairs;
pub mod provenance;
pub mod repeats;
pub mod smoothing;
pub mod xml;

pub use pairs::{
    closest_approach, geometry_index, interaction_id, predicted_closest_distance,
    safe_interactions, safe_interactions_except, step_time, vehicle_state, ClosestApproach,
    EgoChoice, GeometrySet, InteractionRules, PairCounts, SafeInteraction,
};
pub use provenance::{read_event_geometries, PROVENANCE_FILE};
pub use xml::{
    local_origin, parse_scenario, read_scenario, Ignored, Issue, Problem, Scenario, Track,
    TrackState, FAR_COORDINATE_M,
};

/// The scenario id (file stem) an imported event comes from (the event-format convention
/// [`crate::events::recording_of_event_id`]: the part of its id before the first `/`).
pub use crate::events::recording_of_event_id as scenario_of_event_id;

/// What an import read, skipped and wrote.
#[derive(Clone, Debug, Default)]
pub struct ImportSummary {
    /// Scenario files read (at least partly).
    pub files: usize,
    /// Road users imported (tracks).
    pub road_users: usize,
    /// Road users not imported on purpose, by reason.
    pub ignored: BTreeMap<Ignored, usize>,
    /// Files or road users skipped because something is malformed (file, line, element).
    pub issues: Vec<Issue>,
    /// Files whose coordinates reach beyond [`FAR_COORDINATE_M`], with the origin subtracted
    /// from their positions ([`Scenario::origin`]), in file order.
    pub moved_origins: Vec<(String, (f64, f64))>,
    pub counts: PairCounts,
    /// Smallest box gap and centre distance of every written event (m), in event order.
    pub closeness: Vec<(f32, f32)>,
    pub elapsed: Duration,
}

/// The scenario files named by `inputs`: files as given, folders searched recursively for
/// `*.xml` (and compressed `*.xml.gz`, ..., which reading refuses with the format), each
/// folder's entries in name order, symbolic links followed.
///
/// Each real file is listed once and each real folder searched once (compared by device and
/// inode), so a link back up the tree cannot make the search endless, and a file reached by a
/// second path is not read twice: those are returned as issues naming the first path.
pub fn scenario_files(inputs: &[PathBuf]) -> Result<(Vec<PathBuf>, Vec<Issue>), EventsError> {
    let mut search = Search::default();
    for p in inputs {
        search.visit(p, true)?;
    }
    Ok((search.files, search.issues))
}

/// The state of one [`scenario_files`] search.
#[derive(Default)]
struct Search {
    files: Vec<PathBuf>,
    issues: Vec<Issue>,
    /// (device, inode) of every file listed and folder searched, with the path it was first seen at.
    seen: HashMap<(u64, u64), PathBuf>,
}

impl Search {
    /// `given`: named on the command line (a file is then taken whatever its extension).
    fn visit(&mut self, path: &Path, given: bool) -> Result<(), EventsError> {
        use std::os::unix::fs::MetadataExt;
        let Ok(meta) = std::fs::metadata(path) else {
            // A missing input or a dangling link: reading it reports why.
            if given || is_xml(path) {
                self.files.push(path.to_path_buf());
            }
            return Ok(());
        };
        if !meta.is_dir() && !given && !is_xml(path) {
            return Ok(());
        }
        if let Some(first) = self.seen.get(&(meta.dev(), meta.ino())) {
            let first = first.display().to_string();
            self.issues.push(Issue {
                file: path.display().to_string(),
                line: 1,
                context: String::new(),
                problem: if meta.is_dir() {
                    Problem::SameFolder { first }
                } else {
                    Problem::SameFile { first }
                },
            });
            return Ok(());
        }
        self.seen
            .insert((meta.dev(), meta.ino()), path.to_path_buf());
        if !meta.is_dir() {
            self.files.push(path.to_path_buf());
            return Ok(());
        }
        let io = |e| EventsError::Io {
            path: path.to_path_buf(),
            source: e,
        };
        let mut entries: Vec<PathBuf> = std::fs::read_dir(path)
            .map_err(io)?
            .map(|e| e.map(|e| e.path()))
            .collect::<Result<_, _>>()
            .map_err(io)?;
        entries.sort();
        for entry in entries {
            self.visit(&entry, false)?;
        }
        Ok(())
    }
}

/// `*.xml`, and compressed `*.xml.gz` (`.xz`, `.bz2`, `.zst`, `.zip`): listed so that reading
/// them reports the compression instead of the search passing them over in silence.
fn is_xml(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    [
        ".xml", ".xml.gz", ".xml.xz", ".xml.bz2", ".xml.zst", ".xml.zip",
    ]
    .iter()
    .any(|ext| name.ends_with(ext))
}

/// Imports every scenario of `inputs` (files or folders) into the event folder `out`.
///
/// Every interaction's safe sequences become `safe` events (with the partner's recorded
/// acceleration in `acc_sur`), and each gets a row of [`PROVENANCE_FILE`] (scenario, geometry
/// at closest approach). Problems in a file skip that file or road user and are listed in
/// [`ImportSummary::issues`]; everything valid is still written. Two inputs with the same file
/// stem would give clashing event ids: the second is skipped with an issue. Errors only when the
/// output cannot be written or a folder cannot be listed.
pub fn import_to_dir(
    inputs: &[PathBuf],
    out: &Path,
    rules: &InteractionRules,
) -> Result<ImportSummary, EventsError> {
    let started = Instant::now();
    let (files, issues) = scenario_files(inputs)?;
    let mut writer = EventWriter::create_with_partner_acceleration(out)?;
    let mut provenance = ProvenanceWriter::create(out)?;
    let mut summary = ImportSummary {
        issues,
        ..ImportSummary::default()
    };
    let mut seen: HashMap<String, PathBuf> = HashMap::new();
    let mut earlier = EarlierTracks::default();
    for path in &files {
        let scenario = match read_scenario(path) {
            Ok(s) => s,
            Err(issue) => {
                summary.issues.push(issue);
                continue;
            }
        };
        if let Some(first) = seen.get(&scenario.id) {
            summary.issues.push(Issue {
                file: path.display().to_string(),
                line: 1,
                context: String::new(),
                problem: Problem::DuplicateScenario {
                    id: scenario.id.clone(),
                    first: first.display().to_string(),
                },
            });
            continue;
        }
        seen.insert(scenario.id.clone(), path.clone());
        summary.files += 1;
        summary.road_users += scenario.tracks.len();
        if scenario.origin != (0.0, 0.0) {
            summary
                .moved_origins
                .push((path.display().to_string(), scenario.origin));
        }
        for (_, why) in &scenario.ignored {
            *summary.ignored.entry(why.clone()).or_default() += 1;
        }
        summary.issues.extend(scenario.issues.iter().cloned());
        let (found, counts) = if rules.skip_repeats {
            let repeats = earlier.repeats(&scenario);
            earlier.add(summary.files, &scenario);
            safe_interactions_except(&scenario, rules, &repeats)
        } else {
            safe_interactions(&scenario, rules)
        };
        summary.counts.add(&counts);
        for s in found {
            writer.write_event(&s.event)?;
            provenance.write(&scenario.id, &s)?;
            summary.closeness.push((s.min_gap, s.min_centre_distance));
        }
    }
    // No safe sequence found (no scenario could be read, or none held one): nothing to write, so
    // an existing folder is left as it was (dropping the writers removes their temporaries).
    if !summary.closeness.is_empty() {
        writer.finish_with(vec![provenance.into_file()?])?;
    }
    summary.elapsed = started.elapsed();
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenario_id_is_the_part_before_the_first_slash() {
        let id = interaction_id("USA_US101-1_1_T-1", "484", "489", 12);
        assert_eq!(scenario_of_event_id(&id), Some("USA_US101-1_1_T-1"));
        assert_eq!(
            scenario_of_event_id(&format!("{id}#0")),
            Some("USA_US101-1_1_T-1")
        );
        assert_eq!(scenario_of_event_id("sim-17"), None);
        assert_eq!(scenario_of_event_id("/x"), None);
    }
}
