//! `riskctl roadside-passes`: write the safe passes beside stationary roadside objects.
use std::path::PathBuf;

use anyhow::Context;
use riskscore_data::events::EventWriter;
use riskscore_data::sim::roadside_passes::roadside_passes;

/// Write an event folder of 480 safe passes beside stationary roadside objects (van, small
/// object, trailer; 3.25-7 m lateral clearance between the boxes; either side; 2-47 m/s; from
/// 150 m or 40 s before the object to 30 m past it, 10 Hz).
///
/// The grid is disjoint from tests/tests/roadside_objects.rs's (no speed, clearance or object of
/// the test is here), so that test measures generalisation. Use: training-only data for DRL alone,
/// `riskctl demo --extra-drl-only DIR` (scripts/ship-models.sh does; docs/training.md says why
/// not MSRA), and normal driving for `riskctl gssm ship --normal DIR`. Refuses an existing folder.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder (must not exist).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.out.exists() {
        anyhow::bail!("{}: exists; give a new folder", args.out.display());
    }
    let events = roadside_passes();
    let mut writer = EventWriter::create(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    for event in &events {
        writer.write_event(event)?;
    }
    writer.finish()?;
    outln!(
        "wrote {} roadside passes to {}",
        events.len(),
        args.out.display()
    );
    Ok(())
}
