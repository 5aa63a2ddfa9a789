//! `riskctl ablation`: which comparison sources matter, and how much data they need.
use std::path::PathBuf;

use anyhow::{bail, Context};
use riskscore_data::sim::SimConfig;
use riskscore_train::comparisons::Source;
use riskscore_train::train::ablation::{self, AblationOptions, AblationTables};
use riskscore_train::train::cv::Models;
use riskscore_train::train::{Progress, TrainConfig};

/// Train on each comparison source alone and on every combination of sources, over fractions of
/// the training events (default 10 % to 60 %), under event-level cross-validation; print and write
/// the metrics of every cell.
///
/// Without --events the default simulated data set is generated into <out>/data first. This is
/// slow in full (sources x fractions x folds trainings): limit it with --sources, --fractions,
/// --folds and --models. Writes <out>/ablation.csv and <out>/ablation.md when complete.
///
/// `riskctl ablation sim-augmentation --real DIR --sim DIR` runs the simulation-augmentation study
/// instead (simulated comparisons alone, real alone, real + increasing simulated amounts, at a small
/// and a large real budget).
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    #[command(subcommand)]
    pub study: Option<Study>,
    /// Event folder; default: simulate the default data set into <out>/data.
    #[arg(long)]
    pub events: Option<PathBuf>,
    /// A second event folder whose comparisons form the `simulation` source.
    #[arg(long)]
    pub augment: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "out/ablation")]
    pub out: PathBuf,
    /// Training configuration (TOML); default: the built-in defaults.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Sources to combine (comma-separated: temporal, cross_sequence, physics, simulation);
    /// default: the three primary sources, plus simulation when --augment is given.
    #[arg(long, value_delimiter = ',')]
    pub sources: Vec<String>,
    /// Only the single sources and all of them together (not every combination).
    #[arg(long)]
    pub singles_only: bool,
    /// Fractions of each fold's training events (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])]
    pub fractions: Vec<f64>,
    /// Cross-validation folds.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Models to train (comma-separated: drl, msra).
    #[arg(long, value_delimiter = ',', default_values_t = ["drl".to_string(), "msra".to_string()])]
    pub models: Vec<String>,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
}

/// Studies other than the source/fraction grid.
#[derive(clap::Subcommand, Debug)]
pub enum Study {
    /// Simulated comparisons alone, real alone, and real + 0.5x/1x/2x simulated pairs, at a small
    /// and a large real budget (DRL or SSRA).
    SimAugmentation(super::gssm::AugmentationArgs),
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(Study::SimAugmentation(study)) = args.study {
        return super::gssm::run_augmentation(study);
    }
    super::output::refuse_inputs_of(
        &[
            ("--events", args.events.as_deref()),
            ("--augment", args.augment.as_deref()),
        ],
        &[("--config", args.config.as_deref())],
        &[("--out", &args.out)],
    )?;
    super::output::refuse_file_as_folder("--out", &args.out, "ablation.csv and ablation.md")?;
    let config = TrainConfig::load_or_default(args.config.as_deref(), None)?;
    for f in &args.fractions {
        if !(*f > 0.0 && *f <= 1.0) {
            bail!("--fractions: {f} is not in (0, 1]");
        }
    }
    let mut models = Models {
        drl: false,
        drl_f32: false,
        msra: false,
    };
    for m in &args.models {
        match m.trim().to_ascii_lowercase().as_str() {
            "drl" => models.drl = true,
            "msra" => models.msra = true,
            other => bail!("--models: unknown model {other:?} (expected drl, msra)"),
        }
    }
    let mut sources = Vec::new();
    for s in &args.sources {
        match Source::parse(s) {
            Some(src) => sources.push(src),
            None => bail!(
                "--sources: unknown source {s:?} (temporal, cross_sequence, physics, simulation)"
            ),
        }
    }
    if sources.is_empty() {
        sources = vec![Source::Temporal, Source::CrossSequence, Source::Physics];
        if args.augment.is_some() {
            sources.push(Source::Simulation);
        }
    }
    if sources.contains(&Source::Simulation) && args.augment.is_none() {
        bail!("--sources simulation needs --augment DIR");
    }
    // Removed again (while still empty) when the run fails, like every command's new folders.
    let folders = riskscore_output::NewFolders::create(&args.out)
        .with_context(|| format!("{}: cannot create", args.out.display()))?;
    // A simulated folder is staged beside <out>/data and swapped in only once the tables are
    // written: an interrupted or failed run leaves an old one as it was.
    let (events_dir, staged) = match &args.events {
        Some(d) => (d.clone(), None),
        None => {
            let dir = args.out.join("data");
            let cfg = SimConfig {
                progress: !args.quiet,
                ..SimConfig::default()
            };
            eprintln!("simulating the default data set into {}", dir.display());
            let staged = host_tools::demo::simulate_staged(&dir, &cfg)?;
            (dir, Some(staged))
        }
    };
    let events_path = staged.as_ref().map_or(events_dir.as_path(), |s| s.path());
    super::refuse_augmenting_with_itself(events_path, args.augment.as_deref())?;
    let folder = super::load_prepared(events_path)?;
    let (seqs, counts) = (folder.sequences, folder.counts);
    eprintln!(
        "{}: {counts}; {} sequences",
        events_dir.display(),
        seqs.len()
    );
    let aug = match &args.augment {
        Some(d) => Some(super::load_prepared(d)?.sequences),
        None => None,
    };
    let source_sets = if args.singles_only {
        let mut s: Vec<Vec<Source>> = sources.iter().map(|&s| vec![s]).collect();
        if sources.len() > 1 {
            s.push(sources.clone());
        }
        s
    } else {
        ablation::all_combinations(&sources)
    };
    let opts = AblationOptions {
        source_sets,
        fractions: args.fractions.clone(),
        folds: args.folds,
        models,
        progress: if args.quiet {
            Progress::Hidden
        } else {
            Progress::Bar
        },
    };
    let base = ablation::baselines(&seqs, args.folds, config.seed)?;
    let data = format!("{} ({counts})", events_dir.display());
    let mut tables = AblationTables::create(&args.out, &data, args.folds, &base)
        .with_context(|| format!("{}: cannot create the ablation tables", args.out.display()))?;
    ablation::run(&seqs, aug.as_deref(), &config, &opts, |cell| {
        host_tools::warnings::print(&cell.warnings);
        for line in tables.add(cell) {
            outln!("{line}");
        }
    })?;
    let (csv_path, md_path) = tables.finish().context("writing the ablation tables")?;
    host_tools::demo::commit_staged(staged)?;
    folders.keep();
    outln!("wrote {} and {}", csv_path.display(), md_path.display());
    Ok(())
}
