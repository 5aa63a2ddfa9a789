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
    let (set, load_issues) = load_events(dir)?;
    let (sequences, prepare_issues) = prepare_sequences(&set, config);
    if sequences.is_empty() {
        return Err(EventsError::NoSequences {
            path: dir.to_path_buf(),
        });
    }
    Ok(PreparedFolder {
        dir: dir.to_path_buf(),
        sequences,
        counts: set.counts(),
        load_issues,
        prepare_issues,
    })
}

impl PreparedFolder {
    /// The problems as lines for the user (`warning: ...` for rejected rows, `note: ...` for events
    /// without a sequence), the first few listed and the rest counted.
    pub fn problem_notes(&self) -> Vec<String> {
        let skipped = self.prepare_issues.len();
        // The unlisted issues may stand for many problems each (`MoreOfKind`): count problems.
        let unlisted: u64 = self
            .load_issues
            .iter()
            .skip(LISTED_LOAD_ISSUES)
            .map(LoadIssue::count)
            .sum();
        let mut notes = listed("warning", &self.load_issues, LISTED_LOAD_ISSUES, |_| {
            format!("... and {unlisted} more problems")
        });
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
