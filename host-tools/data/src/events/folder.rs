//! An event folder loaded and prepared in one step ([`load_prepared`]), the way training, the demo,
//! the benchmarks and the GSSM commands read their data: the sequences of the valid events plus
//! every problem that left an event out, for the caller to report.
use std::path::{Path, PathBuf};

use super::{
    load_events, prepare_sequences, EventsError, KindCounts, LoadIssue, PrepareConfig,
    PrepareIssue, Sequence,
};

/// Load issues listed one by one by [`PreparedFolder::problem_notes`] before the rest is counted.
pub const LISTED_LOAD_ISSUES: usize = 20;
/// Preparation issues listed one by one by [`PreparedFolder::problem_notes`].
pub const LISTED_PREPARE_ISSUES: usize = 5;

/// The prepared sequences of one event folder and what was left out on the way.
#[derive(Clone, Debug)]
pub struct PreparedFolder {
    pub dir: PathBuf,
    /// One sequence per valid event that satisfies the preparation rules, in `events.csv` order.
    pub sequences: Vec<Sequence>,
    /// The valid events by kind (before preparation).
    pub counts: KindCounts,
    /// Rows or events the loader rejected (file, line, column).
    pub load_issues: Vec<LoadIssue>,
    /// Valid events that yield no sequence under the preparation rules.
    pub prepare_issues: Vec<PrepareIssue>,
}

/// Loads the event folder `dir` ([`load_events`]) and prepares its valid events
/// ([`prepare_sequences`] under `config`). Invalid rows and events without a sequence are kept as
/// issues, not errors; a folder from which no sequence at all comes is
/// [`EventsError::NoSequences`].
pub fn load_prepared(dir: &Path, config: &PrepareConfig) -> Result<PreparedFolder, EventsError> {
    load_and_prepare(dir, config)?.require_sequences()
}

/// [`load_prepared`], also when no sequence comes from the folder: its problems say why, so a
/// caller can show them before [`PreparedFolder::require_sequences`] refuses it.
pub fn load_and_prepare(dir: &Path, config: &PrepareConfig) -> Result<PreparedFolder, EventsError> {
    let (set, load_issues) = load_events(dir)?;
    let (sequences, prepare_issues) = prepare_sequences(&set, config);
    Ok(PreparedFolder {
        dir: dir.to_path_buf(),
        sequences,
        counts: set.counts(),
        load_issues,
        prepare_issues,
    })
}

impl PreparedFolder {
    /// The folder itself, or [`EventsError::NoSequences`] when none of its events yields one.
    pub fn require_sequences(self) -> Result<Self, EventsError> {
        if self.sequences.is_empty() {
            return Err(EventsError::NoSequences { path: self.dir });
        }
        Ok(self)
    }

    /// The problems as lines for the user (`warning: ...` for rejected rows, `note: ...` for events
    /// without a sequence), the first few listed and the rest counted.
    pub fn problem_notes(&self) -> Vec<String> {
        let skipped = self.prepare_issues.len();
        // The unlisted issues may stand for many problems each (`MoreOfKind`): count problems,
        // and the notes (which leave nothing out) apart.
        let (mut problems, mut notes_left) = (0u64, 0u64);
        for issue in self.load_issues.iter().skip(LISTED_LOAD_ISSUES) {
            let count = if issue.problem.is_note() {
                &mut notes_left
            } else {
                &mut problems
            };
            *count += issue.count();
        }
        let mut notes = listed(
            "warning",
            &self.load_issues,
            LISTED_LOAD_ISSUES,
            |_| match (problems, notes_left) {
                (p, 0) => format!("... and {p} more problems"),
                (0, n) => format!("... and {n} more notes"),
                (p, n) => format!("... and {p} more problems and {n} notes"),
            },
        );
        notes.extend(listed(
            "note",
            &self.prepare_issues,
            LISTED_PREPARE_ISSUES,
            |_| format!("... {skipped} events yield no sequence"),
        ));
        notes
    }
}

/// `level: item` for the first `shown` items, then `level: rest(unlisted)` when some are left.
fn listed<T: std::fmt::Display>(
    level: &str,
    items: &[T],
    shown: usize,
    rest: impl FnOnce(usize) -> String,
) -> Vec<String> {
    let mut lines: Vec<String> = items
        .iter()
        .take(shown)
        .map(|i| format!("{level}: {i}"))
        .collect();
    if items.len() > shown {
        lines.push(format!("{level}: {}", rest(items.len() - shown)));
    }
    lines
}
