//! `riskctl gssm`: fit the GSSM, align it (SSRA), combine it with surrogates (MSRA), ship the three
//! models, cross-validate them, and run the simulation-augmentation study.
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use riskscore_data::events::Sequence;
use riskscore_train::gssm::fit::nll_by_speed_band;
use riskscore_train::gssm::msra::{parse_configuration, row_name as msra_row_name};
use riskscore_train::gssm::ship::{ship, SHIPPED_FILES, SUMMARY_FILE};
use riskscore_train::gssm::study::{
    augmentation_study, cross_validate, mean_weights, AugmentationOptions, CvOptions, StudyModel,
};
use riskscore_train::gssm::{
    align_msra_gssm, align_ssra, fit_gssm, weights_table, GssmConfig, GssmParams, TermWeight,
};
use riskscore_train::train::{prepare_comparisons, Progress, TrainConfig};
use scorer_core::gssm::GssmScore;

/// GSSM (lognormal spacing model), SSRA (GSSM aligned with comparisons) and MSRA over GSSM.
///
/// `fit` learns the GSSM from the safe events of folders by lognormal likelihood; `align`
/// fine-tunes it under the comparison objective through its CDF (SSRA); `msra` trains an MSRA
/// configuration that embeds it (e.g. TAdv+EI+GSSM); `ship` does all three and writes
/// gssm-default.rsk, ssra-default.rsk and msra-gssm.rsk; `cv` cross-validates GSSM, SSRA and the
/// MSRA configurations against TTC2D/TAdv/EI; `augmentation` runs the simulation-augmentation
/// study; `nll` says how well a fitted GSSM models the safe driving of other folders. Every model
/// file decodes with the core and loads in `riskctl evaluate`. See docs/gssm.md.
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
    /// How well a fitted GSSM models the safe driving of folders it may not have seen: its mean
    /// lognormal NLL per folder and ego-speed band (lower = closer to that normal driving).
    Nll(NllArgs),
}

#[derive(clap::Args, Debug)]
pub struct NllArgs {
    /// GSSM model file (from `riskctl gssm fit`; an SSRA or MSRA-over-GSSM blob's network too).
    #[arg(long, value_name = "FILE")]
    pub gssm: PathBuf,
    /// Event folder whose safe sequences are scored (repeatable: one table block per folder).
    #[arg(long, value_name = "DIR", required = true)]
    pub events: Vec<PathBuf>,
}

/// `--normal`, flattened into the subcommands that fit a GSSM (`fit`, `ship`, `cv`); `align` and
/// `msra` read the GSSM of `--gssm`, so clap rejects the flag there.
#[derive(clap::Args, Debug)]
pub struct Normal {
    /// Real normal-driving event folder: the GSSM is fitted on the safe sequences of every
    /// `--normal` folder together (a model of normal interactions, as the original GSSM); repeat
    /// it to cover several places, e.g. `--normal data/ngsim-us101-safe --normal
    /// data/ngsim-urban-safe` (freeway and city). Default: the safe sequences of `--events`.
    #[arg(long = "normal", value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
}

/// Data and configuration shared by the subcommands.
#[derive(clap::Args, Debug)]
pub struct Common {
    /// Event folder (events.csv + frames.csv); repeat to train on several, e.g. simulated
    /// conflicts plus real safe driving (`--events out/data --events data/ngsim-us101-safe`).
    #[arg(long, value_name = "DIR", required = true)]
    pub events: Vec<PathBuf>,
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
    #[command(flatten)]
    pub normal: Normal,
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
    /// Output model file (the SSRA); `-` writes it to standard output.
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
    /// Surrogates combined, `+`-separated: ttc2d, tadv, ei, tadv_corridor, gssm.
    #[arg(long, default_value = "tadv_corridor+ei+gssm")]
    pub terms: String,
    /// Output model file (the MSRA over the GSSM); `-` writes it to standard output.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct ShipArgs {
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub normal: Normal,
    /// Folder for gssm-default.rsk, ssra-default.rsk, msra-gssm.rsk and gssm-ship.json.
    #[arg(long, value_name = "DIR")]
    pub out_dir: PathBuf,
    /// MSRA blob (e.g. the `msra.rsk` trained on the same data by `riskctl train`) whose
    /// kinematic terms GSSM and SSRA hand over to outside the normal driving the GSSM was
    /// fitted on (`[guard] policy` `fallback`, or the default `blend`, which the GSSM family is
    /// written with as `fallback`; docs/domain-guard.md). Without it the three models carry a
    /// flag-only record.
    #[arg(long, value_name = "FILE")]
    pub fallback_from: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
pub struct CvArgs {
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub normal: Normal,
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
    /// Also write cv.json (report, folds, per-fold details) here; `-` writes it to standard
    /// output, and the report then goes to stderr.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// MSRA blob whose kinematic terms every fold's GSSM and SSRA hand over to outside the
    /// normal driving the fold's GSSM was fitted on, as `gssm ship --fallback-from` ships them
    /// (docs/domain-guard.md, "The GSSM family"). Without it the fold models are unguarded.
    #[arg(long, value_name = "FILE")]
    pub fallback_from: Option<PathBuf>,
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
        Command::Nll(a) => run_nll(a),
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
    Ok((
        TrainConfig::load_or_default(config, seed)?,
        GssmConfig::load_or_default(gssm_config)?,
    ))
}

/// Prepared sequences of every folder, concatenated.
fn load_all(dirs: &[PathBuf]) -> anyhow::Result<Vec<Sequence>> {
    let mut out = Vec::new();
    for d in dirs {
        out.extend(load_sequences(d)?);
    }
    Ok(out)
}

/// The sequences the GSSM is fitted on: those of every `--normal` folder, else the training
/// sequences.
fn normal_sequences(normal: &[PathBuf], train: &[Sequence]) -> anyhow::Result<Vec<Sequence>> {
    if normal.is_empty() {
        Ok(train.to_vec())
    } else {
        load_all(normal)
    }
}

/// Prepared sequences of an event folder; problems are reported on stderr and their events skipped.
fn load_sequences(dir: &Path) -> anyhow::Result<Vec<Sequence>> {
    Ok(super::load_prepared(dir)?.sequences)
}

fn read_gssm(path: &Path) -> anyhow::Result<GssmParams> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let (params, _) =
        GssmParams::from_blob(&bytes).with_context(|| format!("GSSM model {}", path.display()))?;
    Ok(params)
}

/// Writes a model through the output layer: a file replaced whole, `-` (or another name of
/// standard output) the blob streamed there, as every command that writes one file does.
fn write(path: &Path, blob: &[u8]) -> anyhow::Result<()> {
    super::output::write_file_atomically(path, blob)?;
    eprintln!(
        "riskctl: wrote {} ({} bytes)",
        super::output::output_name(path),
        blob.len()
    );
    Ok(())
}

fn print_weights(name: &str, weights: &[TermWeight]) {
    out!("{}", weights_table(name, weights));
}

/// Refuses an output file that is, or lies inside, one of the inputs of `common` (event folders,
/// configurations), the `normal` folders or `more`.
fn refuse_inputs(
    common: &Common,
    normal: &[PathBuf],
    more: &[(&str, &Path)],
    out: &Path,
) -> anyhow::Result<()> {
    let folders: Vec<(&str, Option<&Path>)> = super::output::repeated("--events", &common.events)
        .chain(super::output::repeated("--normal", normal))
        .collect();
    let mut files: Vec<(&str, Option<&Path>)> = vec![
        ("--config", common.config.as_deref()),
        ("--gssm-config", common.gssm_config.as_deref()),
    ];
    files.extend(more.iter().map(|(f, p)| (*f, Some(*p))));
    super::output::refuse_inputs_of(&folders, &files, &[("--out", out)])
}

/// `--fallback-from`, when given, as an input the output may not overwrite.
fn fallback_input(fallback_from: &Option<PathBuf>) -> Vec<(&'static str, &Path)> {
    fallback_from
        .iter()
        .map(|p| ("--fallback-from", p.as_path()))
        .collect()
}

/// The MSRA terms of `--fallback-from`, when given (the guard keeps its kinematic ones).
fn read_fallback_terms(
    fallback_from: &Option<PathBuf>,
) -> anyhow::Result<Option<Vec<scorer_core::msra::MsraTerm>>> {
    fallback_from
        .as_deref()
        .map(super::calibrate_domain::read_kinematic_terms)
        .transpose()
}

fn run_fit(a: FitArgs) -> anyhow::Result<()> {
    refuse_inputs(&a.common, &a.normal.dirs, &[], &a.out)?;
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let seqs = load_all(&a.common.events)?;
    let g = fit_gssm(
        &normal_sequences(&a.normal.dirs, &seqs)?,
        cfg.optimiser.validation_fraction,
        cfg.seed,
        &gcfg.fit,
        progress(),
    )?;
    // On stderr when the model goes to standard output (`--out -`).
    summaryln!(
        &a.out,
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
    refuse_inputs(&a.common, &[], &[("--gssm", &a.gssm)], &a.out)?;
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let gssm = read_gssm(&a.gssm)?;
    let seqs = load_all(&a.common.events)?;
    let prepared = prepare_comparisons(&seqs, None, &cfg);
    let s = align_ssra(&gssm, &prepared, &cfg, &gcfg.ssra, progress())?;
    summaryln!(
        &a.out,
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
    refuse_inputs(&a.common, &[], &[("--gssm", &a.gssm)], &a.out)?;
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let kinds = parse_configuration(&a.terms).map_err(anyhow::Error::msg)?;
    let gssm = read_gssm(&a.gssm)?;
    let seqs = load_all(&a.common.events)?;
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
    let table = weights_table(&msra_row_name(&kinds), &m.params.weights());
    super::output::summary(&a.out, format_args!("{table}"));
    write(&a.out, &m.params.blob()?)
}

fn run_ship(a: ShipArgs) -> anyhow::Result<()> {
    refuse_inputs(
        &a.common,
        &a.normal.dirs,
        &fallback_input(&a.fallback_from),
        &a.out_dir,
    )?;
    super::output::refuse_file_as_folder(
        "--out-dir",
        &a.out_dir,
        "gssm-default.rsk, ssra-default.rsk, msra-gssm.rsk and gssm-ship.json",
    )?;
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    let fallback_terms = read_fallback_terms(&a.fallback_from)?;
    let seqs = load_all(&a.common.events)?;
    let shipped = ship(
        &seqs,
        &normal_sequences(&a.normal.dirs, &seqs)?,
        &cfg,
        &gcfg,
        fallback_terms.as_deref(),
        progress(),
    )?;
    for warning in &shipped.warnings {
        eprintln!("riskctl: warning: {warning}");
    }
    print_weights(
        &msra_row_name(&shipped.kinds),
        &shipped.msra.params.weights(),
    );
    let summary = shipped.summary(&cfg, &gcfg, &a.common.events, &a.normal.dirs);
    let summary = serde_json::to_string_pretty(&summary)?;
    // The three models and their summary belong together: renamed into place as one set.
    let folders = riskscore_output::NewFolders::create(&a.out_dir)
        .with_context(|| format!("{}: cannot create", a.out_dir.display()))?;
    let mut set = riskscore_output::AtomicSet::default();
    let files = SHIPPED_FILES
        .iter()
        .zip(shipped.blobs.iter().map(Vec::as_slice))
        .chain([(&SUMMARY_FILE, summary.as_bytes())]);
    for (name, bytes) in files {
        let path = a.out_dir.join(name);
        set.create(&path)
            .and_then(|f| std::io::Write::write_all(f, bytes))
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    for path in set.commit()? {
        eprintln!("riskctl: wrote {}", path.display());
    }
    folders.keep();
    Ok(())
}

fn run_cv(a: CvArgs) -> anyhow::Result<()> {
    let (cfg, gcfg) = load_configs(
        a.common.config.as_deref(),
        a.common.gssm_config.as_deref(),
        a.common.seed,
    )?;
    if let Some(out) = &a.out {
        refuse_inputs(
            &a.common,
            &a.normal.dirs,
            &fallback_input(&a.fallback_from),
            out,
        )?;
    }
    let fallback_terms = read_fallback_terms(&a.fallback_from)?;
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
    let normal = if a.normal.dirs.is_empty() {
        None
    } else {
        Some(load_all(&a.normal.dirs)?)
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
        fallback_terms,
    };
    let result = cross_validate(&seqs, normal.as_deref(), &cfg, &gcfg, &options, progress())?;
    for warning in &result.warnings {
        eprintln!("riskctl: warning: {warning}");
    }
    // The report is the summary: on stderr when cv.json goes to standard output (`--out -`), so
    // the stream there is exactly the JSON `--out FILE` writes.
    let mut report = String::new();
    if a.json {
        report = format!(
            "{}\n",
            serde_json::to_string_pretty(&result.report.to_json())?
        );
    } else {
        report.push_str(&result.report.to_markdown());
        report.push('\n');
        for (name, ws) in mean_weights(&result.details) {
            report.push_str(&weights_table(&format!("{name} (mean over runs)"), &ws));
            report.push('\n');
        }
        let kept = result
            .details
            .iter()
            .filter(|d| d.ssra_kept_initial)
            .count();
        report.push_str(&format!(
            "SSRA kept the unaligned GSSM in {kept} of {} runs (no fine-tuned epoch beat it on validation).\n",
            result.details.len()
        ));
    }
    match &a.out {
        Some(out) => super::output::summary(out, format_args!("{report}")),
        None => out!("{report}"),
    }
    if let Some(out) = &a.out {
        let json = serde_json::to_string_pretty(&serde_json::json!({
            "report": result.report.to_json(), "folds": result.folds, "details": result.details,
        }))?;
        // A file replaced whole, `-` (or another name of standard output) streamed there.
        write(out, format!("{json}\n").as_bytes())?;
    }
    Ok(())
}

fn run_nll(a: NllArgs) -> anyhow::Result<()> {
    let gssm = read_gssm(&a.gssm)?;
    outln!("| Folder | Ego speed (m/s) | Safe observations | NLL of ln s (nats) |");
    outln!("|---|---|---:|---:|");
    for dir in &a.events {
        let seqs = load_sequences(dir)?;
        for b in nll_by_speed_band(&gssm, &seqs)? {
            outln!(
                "| {} | {}-{} | {} | {} |",
                dir.display(),
                b.band.0,
                b.band.1,
                b.observations,
                b.nll.map_or("-".into(), |v| format!("{v:.3}"))
            );
        }
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
        outln!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "model": report.model.name(),
                "budgets": report.budgets.iter().map(|b| serde_json::json!({
                    "budget": b.budget, "report": b.report.to_json()})).collect::<Vec<_>>(),
            }))?
        );
    } else {
        out!("{}", report.to_markdown());
    }
    Ok(())
}
