//! `riskctl events-to-candump`: an event folder as 10 Hz CAN traffic in candump -L format.
use anyhow::Context;
use host_tools::candump_export::{write_candump, ExportOptions, DEFAULT_GAP_US, DEFAULT_START_US};
use std::path::PathBuf;

/// Encode an event folder as vehicle CAN traffic (project DBC) in candump -L format.
///
/// Each event frame becomes one 10 Hz cycle of five frames: EGO_MOTION, EGO_SIZE, OBJECT_POSITION,
/// OBJECT_SIZE, OBJECT_MOTION (see can-bridge/dbc/riskscore.dbc), in the ego frame. Events follow
/// each other with a pause; event k is object track k % 256. Replay the log with
/// `can-bridge replay`, score it with `can-bridge score-log`, compare with `can-bridge check`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Event folder (events.csv + frames.csv).
    #[arg(long)]
    pub events: PathBuf,
    /// Output log file (candump -L format).
    #[arg(long)]
    pub out: PathBuf,
    /// Interface name written into each line.
    #[arg(long, default_value = "vcan0")]
    pub iface: String,
    /// Timestamp of the first frame, seconds since the epoch.
    #[arg(long, default_value_t = DEFAULT_START_US as f64 / 1e6)]
    pub start: f64,
    /// Pause between events, seconds.
    #[arg(long, default_value_t = DEFAULT_GAP_US as f64 / 1e6)]
    pub gap: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.start.is_finite() && args.start >= 0.0,
        "--start must be >= 0"
    );
    anyhow::ensure!(
        args.gap.is_finite() && args.gap >= 0.0,
        "--gap must be >= 0"
    );
    let (set, issues) = host_tools::events::load_events(&args.events)
        .with_context(|| format!("loading events from {}", args.events.display()))?;
    for issue in issues.iter().take(20) {
        eprintln!("warning: {issue}");
    }
    if issues.len() > 20 {
        eprintln!(
            "warning: ... {} more problems in the event folder",
            issues.len() - 20
        );
    }
    let opts = ExportOptions {
        iface: args.iface,
        start_us: (args.start * 1e6).round() as u64,
        gap_us: (args.gap * 1e6).round() as u64,
    };
    let file = std::fs::File::create(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let summary = write_candump(&set, &opts, file)
        .with_context(|| format!("writing {}", args.out.display()))?;
    for s in summary.skipped.iter().take(20) {
        eprintln!(
            "warning: event {} at t={}: cycle not encoded: {}",
            s.event_id, s.time, s.reason
        );
    }
    if summary.skipped.len() > 20 {
        eprintln!(
            "warning: ... {} more cycles not encoded",
            summary.skipped.len() - 20
        );
    }
    println!(
        "wrote {}: {} events, {} cycles, {} CAN frames, {:.1} s of traffic{}",
        args.out.display(),
        summary.events,
        summary.cycles,
        summary.can_frames,
        summary.duration_s,
        if summary.skipped.is_empty() {
            String::new()
        } else {
            format!(
                ", {} cycles skipped (out of signal range)",
                summary.skipped.len()
            )
        }
    );
    Ok(())
}
