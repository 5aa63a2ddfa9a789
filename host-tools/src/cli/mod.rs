//! One module per `riskctl` subcommand: argument struct (clap) + `run`, which parses and calls the
//! library crates; plus the one step several commands share, [`load_prepared`] (the demo's too,
//! so it lives in `host_tools::warnings`).
use std::path::Path;

/// `println!` for a command's summary of an output `$out` it wrote: on standard output, or on
/// stderr when `$out` is standard output itself (`--out -`), so that stream holds only the data
/// (see [`output::summary`]).
macro_rules! summaryln {
    ($out:expr, $($arg:tt)*) => {
        $crate::cli::output::summary($out, format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// Writes to standard output, ignoring a closed one (see [`host_tools::print_out`], which the
/// demo prints through too).
pub use host_tools::print_out;

pub mod ablation;
pub mod benchmark;
pub mod calibrate;
pub mod calibrate_domain;
pub mod completions;
pub mod demo;
pub mod evaluate;
pub mod events_to_candump;
pub mod export_model;
pub mod gssm;
pub mod import;
pub mod inspect_model;
pub mod output;
pub mod plot;
pub mod roadside_passes;
#[cfg(feature = "parquet")]
pub mod score;
pub mod simulate;
pub mod ssm;
pub mod train;

/// Refuses `--augment` naming the `--events` folder itself (any spelling or link): its
/// comparisons would repeat the training events' as a "simulation" source and carry the events
/// held out for validation into training, so early stopping would watch data it learns from.
pub fn refuse_augmenting_with_itself(events: &Path, augment: Option<&Path>) -> anyhow::Result<()> {
    let Some(augment) = augment else {
        return Ok(());
    };
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same(events, augment) || same(&events.join("events.csv"), &augment.join("events.csv")) {
        anyhow::bail!(
            "--augment {} is the --events folder {}: its comparisons would repeat the training \
             events' and leak the validation events into training; give --augment a second \
             folder (e.g. simulated events) or leave it out",
            augment.display(),
            events.display()
        );
    }
    Ok(())
}

pub use host_tools::warnings::load_prepared;

/// What the loader leaves out for `issue` (not a note): rows of an event id that is not in
/// events.csv are dropped alone, as there is no such event to skip
/// ([`IssueProblem::UnknownEvent`](riskscore_data::events::IssueProblem::UnknownEvent)); every
/// other problem skips the event it names, or drops its row when no event can be named.
pub(crate) fn left_out(issue: &riskscore_data::events::LoadIssue) -> &'static str {
    use riskscore_data::events::IssueProblem;
    match &issue.problem {
        IssueProblem::UnknownEvent { .. } => "only these rows are dropped: no event is skipped",
        IssueProblem::MoreOfKind { .. } if issue.problem.drops_only_its_rows() => {
            "only those rows are dropped: no event is skipped"
        }
        IssueProblem::MoreOfKind { .. } => "their events are skipped",
        _ if issue.event_id.as_deref().is_some_and(|id| !id.is_empty()) => "the event is skipped",
        _ => "the row is skipped",
    }
}
