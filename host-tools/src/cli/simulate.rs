//! `riskctl simulate`: write a simulated event folder.
use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{bail, Context};
use riskscore_data::sim::{simulate_to_dir, FamilyMix, Mix, SimConfig};

/// Simulate crash, near-crash and safe two-vehicle events at 10 Hz and write an event folder.
///
/// Every event comes from physics: IDM drivers with reaction delay, distraction, gap acceptance,
/// evasive braking and swerving, in rear-end, cut-in, lane-change, merge, crossing, turning and
/// opposite-direction scenarios. The label is read off the trajectories (crash = first box
/// overlap; near-crash = minimum gap < 2 m with an evasive manoeuvre; safe = |acc| <= 1.5 m/s^2
/// throughout); scenarios are drawn until the requested mix is reached. Output: events.csv,
/// frames.csv (docs/event-format.md) and scenarios.csv (per-event provenance, with the family of
/// every event). --families chooses the scenario families: `default` (the original nine; the
/// shipped models were trained on it), `domain` (adds motorway traffic at 25-50 m/s, queues and
/// turns at signalised junctions, roadside objects) or a list. Same seed and families, same files,
/// whatever the thread count. See docs/simulator.md.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder (created; existing event files are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of events (default 310: 70 crash, 110 near-crash, 130 safe, like the 100-Car set).
    /// At least 1 and at most 10,000,000; a count whose folder (about 15 KB an event) would not
    /// fit in the free space of the output's file system is refused before anything is written.
    #[arg(long, default_value_t = 310)]
    pub events: usize,
    /// Relative weights crash,near_crash,safe of the mix.
    #[arg(long, value_name = "C,N,S", default_value = "70,110,130")]
    pub mix: Mix,
    /// Scenario families and their weights: `default` (the original nine families), `domain`
    /// (the original families at half weight plus motorway_approach, motorway_cut_in,
    /// signal_queue, signal_crossing, signal_left_turn, signal_right_turn, roadside_object), or a
    /// list of family names, each optionally weighted (`motorway_approach:2,signal_queue`).
    #[arg(
        long,
        value_name = "default|domain|NAME[:W],...",
        default_value = "default"
    )]
    pub families: FamilyMix,
    /// Worker threads (0 = all cores; at most 4 per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // A run with nothing to write never touches the output (docs/outputs.md): an existing
    // folder would otherwise be replaced by header-only files.
    if args.events == 0 {
        bail!(
            "--events 0: nothing to simulate (at least 1 event); {} is left untouched",
            args.out.display()
        );
    }
    let cfg = SimConfig {
        seed: args.seed,
        events: args.events,
        mix: args.mix,
        families: args.families,
        threads: args.threads,
        progress: std::io::stderr().is_terminal(),
        ..SimConfig::default()
    };
    cfg.check_size(Some(&args.out))?;
    let s = simulate_to_dir(&args.out, &cfg)
        .with_context(|| format!("simulating into {}", args.out.display()))?;
    outln!(
        "wrote {} events ({}) with {} frames to {} (families: {})",
        s.counts.total(),
        s.counts,
        s.frames,
        args.out.display(),
        cfg.families
    );
    outln!(
        "{:.1} s, {:.0} events/s; {} scenarios drawn",
        s.elapsed.as_secs_f64(),
        s.events_per_second(),
        s.attempts
    );
    let rej: Vec<String> = s
        .rejections
        .iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect();
    if !rej.is_empty() {
        outln!("not kept: {}", rej.join(", "));
    }
    for (family, c) in &s.families {
        outln!("  {family:<17} {c}");
    }
    Ok(())
}
