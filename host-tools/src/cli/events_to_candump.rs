//! `riskctl events-to-candump`: an event folder as 10 Hz CAN traffic in candump -L format.
use anyhow::{bail, Context};
use riskscore_data::candump_export::{
    write_candump, ExportOptions, DEFAULT_GAP_US, DEFAULT_START_US,
};
use std::io::Write as _;
use std::path::PathBuf;

/// What `--help` says after the options (a doc comment of [`Args`] is not shown: the
/// subcommand's one-line description in `main.rs` takes its place).
const ABOUT_CANDUMP: &str = "\
Each event frame becomes one 10 Hz cycle of five frames: EGO_MOTION, EGO_SIZE, OBJECT_POSITION,
OBJECT_SIZE, OBJECT_MOTION (see can-bridge/dbc/riskscore.dbc), in the ego frame. Events follow
each other with a pause; event k is object track k % 256. Replay the log with
`can-bridge replay`, score it with `can-bridge score-log`, compare with `can-bridge check`.

A cycle with a value outside its signal's DBC range is never clamped: it is left out of the log
and listed (event id, time, signal). Any left-out cycle fails the run (exit 1, no log written)
unless `--max-skipped` allows that share of the cycles.";

/// Encode an event folder as vehicle CAN traffic (project DBC) in candump -L format (see
/// [`ABOUT_CANDUMP`]).
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_CANDUMP)]
pub struct Args {
    /// Event folder (events.csv + frames.csv).
    #[arg(long)]
    pub events: PathBuf,
    /// Output log file (candump -L format); `-` writes the log to standard output (this
    /// command's other messages then go to stderr). Missing parent folders are created.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Interface name written into each line (at most 15 bytes; no whitespace, `#`, `(`, `)`).
    #[arg(long, default_value = "vcan0", value_parser = iface_name)]
    pub iface: String,
    /// Timestamp of the first frame, seconds since the epoch (0 to 1e10).
    #[arg(long, allow_negative_numbers = true, default_value_t = DEFAULT_START_US as f64 / 1e6, value_parser = start_seconds)]
    pub start: f64,
    /// Pause between events, seconds (0 to 1e6).
    #[arg(long, allow_negative_numbers = true, default_value_t = DEFAULT_GAP_US as f64 / 1e6, value_parser = gap_seconds)]
    pub gap: f64,
    /// Largest share of cycles (0 to 1) that may be left out because a value is outside its
    /// signal's range before the run fails. Default 0: any left-out cycle fails the run.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0, value_name = "FRACTION", value_parser = fraction)]
    pub max_skipped: f64,
}

/// A share in [0, 1].
fn fraction(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        Ok(_) => Err(format!("`{s}` is not a fraction in [0, 1]")),
        Err(_) => Err(format!("`{s}` is not a number")),
    }
}

/// An interface name a candump -L line can carry and be read back with.
fn iface_name(s: &str) -> Result<String, String> {
    can_codec::check_iface_name(s).map(|()| s.to_string())
}

/// Cycles listed one by one; the rest are counted.
const LISTED_SKIPS: usize = 20;

fn seconds_in(s: &str, max: f64) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=max).contains(&v) => Ok(v),
        Ok(_) => Err(format!("`{s}` is outside [0, {max}] s")),
        Err(_) => Err(format!("`{s}` is not a number")),
    }
}

/// Log start: up to 1e10 s (year 2286), so microsecond timestamps stay exact in `u64`.
fn start_seconds(s: &str) -> Result<f64, String> {
    seconds_in(s, 1e10)
}

/// Pause between events: up to 1e6 s (11 days).
fn gap_seconds(s: &str) -> Result<f64, String> {
    seconds_in(s, 1e6)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    super::output::refuse_inputs_of(
        &[("--events", Some(args.events.as_path()))],
        &[],
        &[("--out", args.out.as_path())],
    )?;
    super::output::refuse_overwriting_a_model("--out", &args.out, "a candump log")?;
    let (set, issues) = riskscore_data::events::load_events(&args.events)
        .with_context(|| format!("loading events from {}", args.events.display()))?;
    // The loader keeps the first problems of each kind and counts the rest.
    for issue in &issues {
        if issue.problem.is_note() {
            eprintln!("riskctl: note: {issue}");
        } else {
            eprintln!("riskctl: warning: {issue} ({})", super::left_out(issue));
        }
    }
    if set.is_empty() {
        bail!(
            "no event in {}: nothing written, {}",
            args.events.display(),
            super::output::left_alone(&args.out)
        );
    }
    let opts = ExportOptions {
        iface: args.iface,
        start_us: (args.start * 1e6).round() as u64,
        gap_us: (args.gap * 1e6).round() as u64,
    };
    // A file is written under a temporary name and renamed at the end: a failed run leaves no
    // half log. `-` (or /dev/stdout) streams the log to standard output, and everything else
    // this command says goes to stderr.
    let frames_csv = args.events.join(riskscore_data::events::FRAMES_FILE);
    let out = args.out.as_path();
    let written = super::output::write_output(out, |mut w| {
        let summary = write_candump(&set, &opts, &mut w)
            .with_context(|| format!("writing {}", out.display()))?;
        let skipped = summary.skipped.len();
        for s in summary.skipped.iter().take(LISTED_SKIPS) {
            eprintln!(
                "{}: event {} at t={}: cycle not encoded: {}",
                frames_csv.display(),
                s.event_id,
                s.time,
                s.reason
            );
        }
        if skipped > LISTED_SKIPS {
            eprintln!(
                "{}: ... {} more cycles not encoded",
                frames_csv.display(),
                skipped - LISTED_SKIPS
            );
        }
        if skipped > 0 {
            let all = summary.cycles + skipped;
            let share = skipped as f64 / all as f64;
            let what = format!(
                "{}: {skipped} of {all} cycles ({:.3}%) not encoded (a value outside its signal's DBC range), in {} event(s)",
                frames_csv.display(),
                share * 100.0,
                summary.events_with_skips()
            );
            if share > args.max_skipped {
                // The file is dropped without commit: no log is written (on standard output
                // the lines are gone already; the exit status says the log is incomplete).
                bail!(
                    "{what}; more than --max-skipped {}: {} not written",
                    args.max_skipped,
                    out.display()
                );
            }
            eprintln!(
                "warning: {what} (within --max-skipped {})",
                args.max_skipped
            );
        }
        w.flush()
            .with_context(|| format!("writing {}", out.display()))?;
        Ok(summary)
    })?;
    // `None`: the reader of standard output went away (`| head`), a normal end for a filter.
    let Some(summary) = written else {
        return Ok(());
    };
    let skipped = summary.skipped.len();
    summaryln!(
        out,
        "wrote {}: {} events, {} cycles, {} CAN frames, {:.1} s of traffic{}",
        super::output::output_name(out),
        summary.events,
        summary.cycles,
        summary.can_frames,
        summary.duration_s,
        if skipped == 0 {
            String::new()
        } else {
            format!(", {skipped} cycles skipped (out of signal range)")
        }
    );
    Ok(())
}
