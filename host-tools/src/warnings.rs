//! Showing the warnings the library crates return instead of printing (a fold whose DRL got no
//! kinematic fallback, ...): one line each on stderr, after the stage that produced them.

use std::path::Path;

use riskscore_data::events::{self, EventsError, PrepareConfig, PreparedFolder};

/// The prepared sequences of an event folder ([`events::load_prepared`] under the default
/// preparation rules); its problems are printed on stderr, `riskctl: <folder>: ...`, and those
/// events left out. They are printed also when no sequence is left (then an error): they are why.
pub fn load_prepared(dir: &Path) -> Result<PreparedFolder, EventsError> {
    let folder = events::load_and_prepare(dir, &PrepareConfig::default())?;
    for note in folder.problem_notes() {
        eprintln!("riskctl: {}: {note}", dir.display());
    }
    folder.require_sequences()
}

/// Print each warning as `riskctl: warning: <text>` on stderr.
pub fn print<'a>(warnings: impl IntoIterator<Item = &'a String>) {
    for warning in warnings {
        eprintln!("riskctl: warning: {warning}");
    }
}
