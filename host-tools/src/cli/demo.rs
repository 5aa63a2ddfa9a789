//! `riskctl demo`: the end-to-end main job on the default simulated data set.
use std::path::PathBuf;

use anyhow::Context;
use host_tools::demo::{
    self, DemoOptions, DomainSettings, ExtraSim, ExtraTraining, TransferSettings,
};
use riskscore_data::sim::{FamilyMix, Mix};
use riskscore_train::train::{Progress, TrainConfig};

/// What `--help` says after the options (a doc comment of [`Args`] is not shown: the
/// subcommand's one-line description in `main.rs` takes its place).
const ABOUT_DEMO: &str = "\
Simulate the default data set, add the real safe driving of the committed NGSIM US-101 extract
(data/ngsim-us101-safe), train DRL and MSRA under 5-fold event-level cross-validation, print the
results table against TTC2D, TAdv and EI, run the transfer benchmark (train on this simulator
seed + part of the real scenario files, test on another seed and event mix + the held-out real
files), run a short domain benchmark (train without the 35-50 m/s band, one city's real traffic,
or crossing/oncoming encounters, test on it; 2 folds x 1 seed of `riskctl benchmark domains`),
quantise and export the final models, and write plots.

The recipe (docs/training.md \"Training on the operating domain\"): the sets the benchmarks test
on (the simulated default set and the real freeway extract) plus training-only data that joins
every training fold, the transfer benchmark's training side and the final models but never a
test fold: a simulated folder of the operating-domain families (motorway, signalised junctions,
roadside objects; seed 3) and the real city extract (data/ngsim-urban-safe). `--no-extra` runs
the recipe before issue #18.

Everything goes under --out (default ./out): data/ (the simulated events), extra-data/ (the
training-only simulated folder), transfer-data/ (the transfer test simulation), domains-data/
(the domain benchmark's simulated folders), report/ (results.md/csv/json, folds.csv, curves.csv,
training.json, transfer/, domains/), models/ (drl.rsk, drl-f32.rsk, msra.rsk and their JSON
checkpoints), plots/ (ROC, PR, risk trajectories as SVG and PNG).";

/// Simulate the default data set, add the real safe driving of the committed NGSIM US-101 extract
/// (data/ngsim-us101-safe), train DRL and MSRA under 5-fold event-level cross-validation, print the
/// results table against TTC2D, TAdv and EI, run the transfer benchmark (train on this simulator
/// seed + part of the real scenario files, test on another seed and event mix + the held-out real
/// files), run a short domain benchmark (train without the 35-50 m/s band, one city's real traffic,
/// or crossing/oncoming encounters, test on it; 2 folds x 1 seed of `riskctl benchmark domains`),
/// quantise and export the final models, and write plots.
///
/// The rest: [`ABOUT_DEMO`].
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_DEMO)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Training configuration (TOML); default: the built-in defaults (= configs/train.toml).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Override the training seed of the configuration.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Simulator seed of the data set.
    #[arg(long, default_value_t = DemoOptions::default().sim_seed)]
    pub sim_seed: u64,
    /// Number of simulated events.
    #[arg(long, default_value_t = DemoOptions::default().events)]
    pub events: usize,
    /// Use this event folder instead of simulating one.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Number of cross-validation folds.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Cross-validation repetitions with seeds seed, seed+1, ... (fold assignment and training).
    #[arg(long, default_value_t = 3)]
    pub seeds: usize,
    /// Real normal-driving event folder added to training (safe sequences) and used by the transfer
    /// benchmark; default: the committed extract data/ngsim-us101-safe when it is found.
    #[arg(long, value_name = "DIR", conflicts_with = "no_real")]
    pub real: Option<PathBuf>,
    /// Simulation only: no real recordings, neither tested nor training-only (and no transfer
    /// benchmark).
    #[arg(long, conflicts_with = "extra_real")]
    pub no_real: bool,
    /// Scenario families of the training-only simulated folder (`default`, `domain` or a list, as
    /// `riskctl simulate --families`).
    #[arg(
        long,
        value_name = "default|domain|NAME[:W],...",
        default_value = "domain",
        conflicts_with = "no_extra"
    )]
    pub extra_families: FamilyMix,
    /// Events in the training-only simulated folder (0: none).
    #[arg(long, value_name = "N", default_value_t = ExtraSim::default().events, conflicts_with = "no_extra")]
    pub extra_events: usize,
    /// Simulator seed of the training-only simulated folder (keep it apart from --sim-seed, the
    /// transfer seed and any folder you test on).
    #[arg(long, value_name = "SEED", default_value_t = ExtraSim::DEFAULT_SEED, conflicts_with = "no_extra")]
    pub extra_seed: u64,
    /// Training-only real normal-driving folder (repeatable); default: the committed city extract
    /// data/ngsim-urban-safe when it is found.
    #[arg(long = "extra-real", value_name = "DIR", conflicts_with = "no_extra")]
    pub extra_real: Vec<PathBuf>,
    /// Training-only event folder that DRL alone trains on (repeatable): it joins DRL's side of
    /// every training fold, of the transfer benchmark's training side and of the final DRL, never
    /// a test fold, never MSRA's training (nor the domain benchmark's). For data MSRA's kinematic
    /// inputs cannot tell from a conflict, e.g. `riskctl roadside-passes --out DIR` (passes beside
    /// stationary roadside objects; scripts/ship-models.sh gives them to DRL this way).
    #[arg(
        long = "extra-drl-only",
        value_name = "DIR",
        conflicts_with = "no_extra"
    )]
    pub extra_drl_only: Vec<PathBuf>,
    /// No training-only data: train on the tested sets alone (the recipe before issue #18).
    #[arg(long)]
    pub no_extra: bool,
    /// Skip the transfer benchmark (and the domain benchmark, which uses its test seed and mix).
    #[arg(long)]
    pub no_transfer: bool,
    /// Skip the short domain benchmark (held-out speed band, city and geometry; the full run is
    /// `riskctl benchmark domains`).
    #[arg(long)]
    pub no_domains: bool,
    /// Simulator seed of the transfer benchmark's test folder.
    #[arg(long, default_value_t = TransferSettings::default().test_seed)]
    pub transfer_seed: u64,
    /// Event mix crash,near_crash,safe of the transfer benchmark's test folder.
    #[arg(long, value_name = "C,N,S", default_value = "100,60,150")]
    pub transfer_mix: Mix,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let extra_real: Vec<(&str, Option<&std::path::Path>)> =
        super::output::repeated("--extra-real", &args.extra_real)
            .chain(super::output::repeated(
                "--extra-drl-only",
                &args.extra_drl_only,
            ))
            .collect();
    super::output::refuse_inputs_of(
        &[
            [
                ("--data", args.data.as_deref()),
                ("--real", args.real.as_deref()),
            ]
            .as_slice(),
            &extra_real,
        ]
        .concat(),
        &[("--config", args.config.as_deref())],
        &[("--out", &args.out)],
    )?;
    let config = TrainConfig::load_or_default(args.config.as_deref(), args.seed)?;
    let opts = DemoOptions {
        out: args.out,
        config,
        sim_seed: args.sim_seed,
        events: args.events,
        data: args.data,
        folds: args.folds,
        seeds: args.seeds,
        real: if args.no_real {
            None
        } else {
            match args.real {
                Some(dir) => Some(dir),
                None => host_tools::demo::default_real_data(),
            }
        },
        transfer: (!args.no_transfer).then(|| TransferSettings {
            test_seed: args.transfer_seed,
            test_mix: args.transfer_mix,
            ..TransferSettings::default()
        }),
        gssm: riskscore_train::gssm::GssmConfig::default(),
        domains: (!args.no_domains).then(DomainSettings::default),
        extra: if args.no_extra {
            ExtraTraining::none()
        } else {
            ExtraTraining {
                sim: (args.extra_events > 0).then_some(ExtraSim {
                    seed: args.extra_seed,
                    events: args.extra_events,
                    families: args.extra_families,
                }),
                // --no-real: no real recordings at all, training-only ones included.
                real: if args.no_real {
                    Vec::new()
                } else if args.extra_real.is_empty() {
                    ExtraTraining::default().real
                } else {
                    args.extra_real
                },
                drl_only: args.extra_drl_only,
            }
        },
        progress: if args.quiet {
            Progress::Hidden
        } else {
            Progress::Bar
        },
    };
    demo::run(&opts).context("demo failed")?;
    Ok(())
}
