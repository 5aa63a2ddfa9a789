//! `riskctl gssm`: fit the GSSM, align it (SSRA), combine it with surrogates (MSRA), ship the three
//! models, cross-validate them, and run the simulation-augmentation study.
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use host_tools::comparisons::{from_sequences, TrainingSequence};
use host_tools::events::{load_events, prepare_sequences, PrepareConfig, Sequence};
use host_tools::export::write_blob;
use host_tools::gssm::msra::{configuration_name, parse_configuration, row_name as msra_row_name};
use host_tools::gssm::study::{
    augmentation_study, cross_validate, mean_weights, AugmentationOptions, CvOptions, StudyModel,
};
use host_tools::gssm::{align_msra_gssm, align_ssra, fit_gssm, GssmConfig, GssmParams, TermWeight};
use host_tools::train::{prepare_comparisons, Progress, TrainConfig};
use scorer_core::gssm::GssmScore;

/// GSSM (lognormal spacing model), SSRA (GSSM aligned with comparisons) and MSRA over GSSM.
///
/// `fit` learns the GSSM from the safe events of a folder by lognormal likelihood; `align`
/// fine-tunes it under the comparison objective through its CDF (SSRA); `msra` trains an MSRA
/// configuration that embeds it (e.g. TAdv+EI+GSSM); `ship` does all three and writes
/// gssm-default.rsk, ssra-default.rsk and msra-gssm.rsk; `cv` cross-validates GSSM, SSRA and the
/// MSRA configurations against TTC2D/TAdv/EI; `augmentation` runs the simulation-augmentation
/// study. Every model file decodes with the core and loads in `riskctl evaluate`. See docs/gssm.md.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Fit the GSSM on the safe events of a folder and write it (score: intensity).
    Fit(FitArgs),
    /// Fine-tune a GSSM under the comparison objective (SSRA) and write it (score: logit of F_S).
    Align(AlignArgs),
    /// Train an MSRA configuration that reads a GSSM, print its weights, write the blob.
    Msra(MsraArgs),
    /// Fit, align and combine on one folder; write the three shipped models and a summary.
    Ship(ShipArgs),
    /// K-fold event-level CV of GSSM, SSRA and MSRA configurations against the baselines.
    Cv(CvArgs),
    /// Simulation augmentation: sim only, real only, real + more sim, at small and large budgets.
    Augmentation(AugmentationArgs),
}

/// Data and configuration shared by the subcommands.
#[derive(clap::Args, Debug)]
pub struct Common {
    /// Event folder (events.csv + frames.csv); repeat to train on several, e.g. simulated
    /// conflicts plus real safe driving (`--events out/data --events data/ngsim-us101-safe`).
    #[arg(long, value_name = "DIR", required = true)]
    pub events: Vec<PathBuf>,
    /// Real normal-driving event folder: the GSSM is fitted on its safe sequences (a model of
    /// normal interactions, as the original GSSM). Default: the safe sequences of `--events`.
    #[arg(long, value_name = "DIR")]
    pub normal: Option<PathBuf>,
    /// Training configuration TOML (comparisons, objective, optimiser); defaults when absent.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// GSSM configuration TOML ([fit], [ssra], [msra]); defaults when absent (docs/gssm.md).
    #[arg(long = "gssm-config", value_name = "FILE")]
    pub gssm_config: Option<PathBuf>,
    /// Overrides the configuration's seed.
    #[arg(long)]
    pub seed: Option<u64>,
}

#[derive(clap::Args, Debug)]
pub struct FitArgs {
    #[command(flatten)]
    pub common: Common,
    /// Output model file.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct AlignArgs {
    #[command(flatten)]
    pub common: Common,
    /// The GSSM model file to align (from `riskctl gssm fit`).
    #[arg(long, value_name = "FILE")]
    pub gssm: PathBuf,
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct MsraArgs {
    #[command(flatten)]
    pub common: Common,
    /// The GSSM model file the GSSM term reads (embedded in the output).
    #[arg(long, value_name = "FILE")]
    pub gssm: PathBuf,
    /// Surrogates combined, `+`-separated: ttc2d, tadv, ei, gssm.
    #[arg(long, default_value = "tadv+ei+gssm")]
    pub terms: String,
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct ShipArgs {
    #[command(flatten)]
    pub common: Common,
    /// Folder for gssm-default.rsk, ssra-default.rsk, msra-gssm.rsk and gssm-ship.json.
    #[arg(long, value_name = "DIR")]
    pub out_dir: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct CvArgs {
    #[command(flatten)]
    pub common: Common,
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Comma-separated CV seeds (one CV run each); default: the configuration's seed.
    #[arg(long, value_delimiter = ',')]
    pub seeds: Vec<u64>,
    /// MSRA configurations (repeatable), e.g. `--msra ei+gssm --msra tadv+ei+gssm`; default: the
    /// GSSM configuration's list.
    #[arg(long = "msra")]
    pub msra: Vec<String>,
    /// Print JSON instead of Markdown.
    #[arg(long)]
    pub json: bool,
    /// Also write cv.json (report, folds, per-fold details) here.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// The augmentation study's flags (flatten into `riskctl ablation` as well).
#[derive(clap::Args, Debug)]
pub struct AugmentationArgs {
    /// The "real" event folder (tests are its folds).
    #[arg(long, value_name = "DIR")]
    pub real: PathBuf,
    /// The simulated event folder (different simulator settings/seed).
    #[arg(long, value_name = "DIR")]
    pub sim: PathBuf,
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    #[arg(long = "gssm-config", value_name = "FILE")]
    pub gssm_config: Option<PathBuf>,
    #[arg(long)]
    pub seed: Option<u64>,
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Real budgets as fractions of each fold's training events.
    #[arg(long, value_delimiter = ',', default_value = "0.2,1.0")]
    pub budgets: Vec<f64>,
    /// Simulated pairs as multiples of the real pair target.
    #[arg(long = "sim-ratios", value_delimiter = ',', default_value = "0.5,1,2")]
    pub sim_ratios: Vec<f64>,
    /// Parameterisation trained: ssra or drl.
    #[arg(long, default_value = "ssra")]
    pub model: String,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Fit(a) => run_fit(a),
        Command::Align(a) => run_align(a),
        Command::Msra(a) => run_msra(a),
        Command::Ship(a) => run_ship(a),
        Command::Cv(a) => run_cv(a),
        Command::Augmentation(a) => run_augmentation(a),
    }
}

fn progress() -> Progress {
    if std::io::stderr().is_terminal() {
        Progress::Bar
    } else {
        Progress::Hidden
    }
}

fn load_configs(
    config: Option<&Path>,
    gssm_config: Option<&Path>,
    seed: Option<u64>,
) -> anyhow::Result<(TrainConfig, GssmConfig)> {
    let mut train = match config {
        Some(p) => TrainConfig::load(p)?,
        None => TrainConfig::default(),
    };
    if let Some(s) = seed {
        train.seed = s;
    }
    let gssm = match gssm_config {
        Some(p) => GssmConfig::load(p)?,
        None => GssmConfig::default(),
    };
    Ok((train, gssm))
}

/// Prepared sequences of every folder, concatenated.
fn load_all(dirs: &[PathBuf]) -> anyhow::Result<Vec<Sequence>> {
    let mut out = Vec::new();
    for d in dirs {
        out.extend(load_sequences(d)?);
    }
    Ok(out)
}

/// The sequences the GSSM is fitted on: `--normal` when given, else the training sequences.
fn normal_sequences(
    common: &Common,
    train: &[TrainingSequence],
) -> anyhow::Result<Vec<TrainingSequence>> {
    match &common.normal {
        Some(dir) => Ok(from_sequences(&load_sequences(dir)?)),
        None => Ok(train.to_vec()),
    }
}

/// Prepared sequences of an event folder; problems are reported on stderr and their events skipped.
fn load_sequences(dir: &Path) -> anyhow::Result<Vec<Sequence>> {
    let (set, issues) =
        load_events(dir).with_context(|| format!("event folder {}", dir.display()))?;
    if !issues.is_empty() {
        eprintln!(
            "riskctl: {} problem(s) in {} (those events are skipped); first: {}",
            issues.len(),
            dir.display(),
            issues[0]
        );
    }
    let (seqs, prep) = prepare_sequences(&set, &PrepareConfig::default());
    if !prep.is_empty() {
        eprintln!(
            "riskctl: {} event(s) of {} yield no sequence; first: {}",
            prep.len(),
            dir.display(),
            prep[0]
        );
    }
    if seqs.is_empty() {
        bail!("event folder {}: no usable sequences", dir.display());
    }
    Ok(seqs)
}

fn read_gssm(path: &Path) -> anyhow::Result<GssmParams> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let (params, _) =
        GssmParams::from_blob(&bytes).with_context(|| format!("GSSM model {}", path.display()))?;
    Ok(params)
}

fn write(path: &Path, blob: &[u8]) -> anyhow::Result<()> {
    write_blob(path, blob)?;
    eprintln!("riskctl: wrote {} ({} bytes)", path.display(), blob.len());
    Ok(())
}

fn print_weights(name: &str, weights: &[TermWeight]) {
    println!("{name}: learned weights after sigmoid normalisation");
    println!("| term | w | a | b | span | share | risk-consistent |");
    println!("|---|---|---|---|---|---|---|");
    for w in weights {
        println!(
            "| {} | {:+.4} | {:+.4} | {:+.4} | {:+.4} | {:+.3} | {} |",
            w.surrogate, w.w, w.a, w.b, w.span, w.share, w.risk_consistent
        );
    }
}

fn run_fit(a: FitArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let seqs = from_sequences(&load_all(&a.common.events)?);
    let g = fit_gssm(
        &normal_sequences(&a.common, &seqs)?,
        cfg.optimiser.validation_fraction,
        cfg.seed,
        &gcfg.fit,
        progress(),
    )?;
    println!(
        "GSSM {}: {} safe observations ({} validation), {} epochs (best {}), NLL train {:.4} validation {}",
        g.params.shape(),
        g.report.observations,
        g.report.validation_observations,
        g.report.epochs,
        g.report.best_epoch,
        g.report.train_nll,
        g.report.validation_nll.map_or("-".into(), |v| format!("{v:.4}"))
    );
    write(&a.out, &g.params.gssm_blob(GssmScore::Intensity)?)
}

fn run_align(a: AlignArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let gssm = read_gssm(&a.gssm)?;
    let seqs = from_sequences(&load_all(&a.common.events)?);
    let prepared = prepare_comparisons(&seqs, None, &cfg);
    let s = align_ssra(&gssm, &prepared, &cfg, &gcfg.ssra, progress())?;
    println!(
        "SSRA: {} pairs, {} epochs (best {}), validation objective {} -> {}{}",
        s.report.pairs,
        s.report.epochs,
        s.report.best_epoch,
        s.initial_validation
            .map_or("-".into(), |p| format!("{:.4}", p.total)),
        s.final_validation
            .map_or("-".into(), |p| format!("{:.4}", p.total)),
        if s.kept_initial {
            " (no epoch beat the GSSM: kept it)"
        } else {
            ""
        }
    );
    write(&a.out, &s.blob()?)
}

fn run_msra(a: MsraArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let kinds = parse_configuration(&a.terms).map_err(anyhow::Error::msg)?;
    let gssm = read_gssm(&a.gssm)?;
    let seqs = from_sequences(&load_all(&a.common.events)?);
    let prepared = prepare_comparisons(&seqs, None, &cfg);
    let m = align_msra_gssm(
        &kinds,
        &gssm,
        &seqs,
        &prepared,
        &cfg,
        gcfg.msra.learning_rate,
        progress(),
    )?;
    print_weights(&msra_row_name(&kinds), &m.params.weights());
    write(&a.out, &m.params.blob()?)
}

fn run_ship(a: ShipArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let kinds = parse_configuration(&gcfg.msra.shipped).map_err(anyhow::Error::msg)?;
    let seqs = from_sequences(&load_all(&a.common.events)?);
    let g = fit_gssm(
        &normal_sequences(&a.common, &seqs)?,
        cfg.optimiser.validation_fraction,
        cfg.seed,
        &gcfg.fit,
        progress(),
    )?;
    let prepared = prepare_comparisons(&seqs, None, &cfg);
    let s = align_ssra(&g.params, &prepared, &cfg, &gcfg.ssra, progress())?;
    let m = align_msra_gssm(
        &kinds,
        &g.params,
        &seqs,
        &prepared,
        &cfg,
        gcfg.msra.learning_rate,
        progress(),
    )?;
    let gssm_blob = g.params.gssm_blob(GssmScore::Intensity)?;
    let ssra_blob = s.blob()?;
    let msra_blob = m.params.blob()?;
    write(&a.out_dir.join("gssm-default.rsk"), &gssm_blob)?;
    write(&a.out_dir.join("ssra-default.rsk"), &ssra_blob)?;
    write(&a.out_dir.join("msra-gssm.rsk"), &msra_blob)?;
    print_weights(&msra_row_name(&kinds), &m.params.weights());
    let summary = serde_json::json!({
        "events": a.common.events.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "normal": a.common.normal.as_ref().map(|p| p.display().to_string()),
        "sequences": seqs.len(),
        "seed": cfg.seed,
        "gssm": {"shape": g.params.shape(), "parameters": g.params.parameter_count(),
                 "fit": g.report, "bytes": gssm_blob.len()},
        "ssra": {"epochs": s.report.epochs, "best_epoch": s.report.best_epoch, "pairs": s.report.pairs,
                 "validation_before": s.initial_validation.map(|p| p.total),
                 "validation_after": s.final_validation.map(|p| p.total),
                 "kept_initial": s.kept_initial, "bytes": ssra_blob.len()},
        "msra": {"configuration": configuration_name(&kinds), "weights": m.params.weights(),
                 "epochs": m.report.epochs, "bytes": msra_blob.len()},
        "train_config": cfg, "gssm_config": gcfg,
    });
    let path = a.out_dir.join("gssm-ship.json");
    std::fs::write(&path, serde_json::to_string_pretty(&summary)?)
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("riskctl: wrote {}", path.display());
    Ok(())
}

fn run_cv(a: CvArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let names = if a.msra.is_empty() {
        gcfg.msra.configurations.clone()
    } else {
        a.msra.clone()
    };
    let configurations = names
        .iter()
        .map(|c| parse_configuration(c).map_err(anyhow::Error::msg))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let seqs = load_all(&a.common.events)?;
    let normal = match &a.common.normal {
        Some(dir) => Some(from_sequences(&load_sequences(dir)?)),
        None => None,
    };
    let options = CvOptions {
        folds: a.folds.max(2),
        seeds: if a.seeds.is_empty() {
            vec![cfg.seed]
        } else {
            a.seeds.clone()
        },
        configurations,
        baselines: true,
    };
    let result = cross_validate(&seqs, normal.as_deref(), &cfg, &gcfg, &options, progress())?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&result.report.to_json())?
        );
    } else {
        print!("{}", result.report.to_markdown());
        println!();
        for (name, ws) in mean_weights(&result.details) {
            print_weights(&format!("{name} (mean over runs)"), &ws);
            println!();
        }
        let kept = result
            .details
            .iter()
            .filter(|d| d.ssra_kept_initial)
            .count();
        println!(
            "SSRA kept the unaligned GSSM in {kept} of {} runs (no fine-tuned epoch beat it on validation).",
            result.details.len()
        );
    }
    if let Some(out) = &a.out {
        write_blob(
            out,
            serde_json::to_string_pretty(&serde_json::json!({
                "report": result.report.to_json(), "folds": result.folds, "details": result.details,
            }))?
            .as_bytes(),
        )?;
        eprintln!("riskctl: wrote {}", out.display());
    }
    Ok(())
}

/// The simulation-augmentation study (also the entry point for `riskctl ablation`).
pub fn run_augmentation(a: AugmentationArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(a.config.as_deref(), a.gssm_config.as_deref(), a.seed)?;
    let model = StudyModel::parse(&a.model)
        .with_context(|| format!("--model {:?}: expected ssra or drl", a.model))?;
    if a.budgets.iter().any(|b| !(*b > 0.0 && *b <= 1.0)) {
        bail!("--budgets: fractions in (0, 1] required");
    }
    if a.sim_ratios.iter().any(|r| !(*r > 0.0 && r.is_finite())) {
        bail!("--sim-ratios: positive multiples required");
    }
    let real = load_sequences(&a.real)?;
    let sim = load_sequences(&a.sim)?;
    let options = AugmentationOptions {
        folds: a.folds.max(2),
        seed: cfg.seed,
        budgets: a.budgets.clone(),
        sim_ratios: a.sim_ratios.clone(),
        model,
    };
    let report = augmentation_study(&real, &sim, &cfg, &gcfg, &options, progress())?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "model": report.model.name(),
                "budgets": report.budgets.iter().map(|b| serde_json::json!({
                    "budget": b.budget, "report": b.report.to_json()})).collect::<Vec<_>>(),
            }))?
        );
    } else {
        print!("{}", report.to_markdown());
    }
    Ok(())
}
