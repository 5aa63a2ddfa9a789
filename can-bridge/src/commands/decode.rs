//! `can-bridge decode`: every scored track update of a candump log, as the scorer saw it, to a
//! CSV or Parquet table (or stdout), through the same engine as `score-log`; then the sanity
//! report. This is how a user checks a map's signs, offsets and units (docs/can-bridge.md).
use super::args::DecodeArgs;
use super::setup::{
    engine_config, load_map, print_inputs, refuse_empty_log, refuse_nothing_scored,
    refuse_stuck_timestamps, scoring_inputs, summary,
};
use super::{writing, Failure, InputError};
use crate::cli_values::is_std_stream;
use crate::engine::{Engine, EngineConfig, Output};
use crate::events_out::ProblemPrinter;
use crate::logfile;
use crate::losses::{self, FrameLosses};
use crate::model_file::ModelFile;
use crate::offline::LogFeed;
use crate::states_out::StatesWriter;
use riskscore_output::{refuse_overlaps, refuse_overwriting_a_model, AtomicFile};
use scorer_core::model::{BoundedVec, Model};
use scorer_core::msra::MsraModel;
use std::io::Write;
use std::path::Path;

pub fn run_decode(args: DecodeArgs) -> Result<(), Failure> {
    let model_file = match &args.scoring.model {
        Some(p) => Some(ModelFile::load(p)?),
        None => None,
    };
    let scoring = args.scoring.as_scoring();
    let map = load_map(&scoring)?;
    print_inputs(&map);
    let (model, config) = match &model_file {
        Some(m) => (m.blob()?, engine_config(&scoring, m)?),
        None => (no_model().into(), states_only_config(&scoring)),
    };
    let mut engine = Engine::new(model, map, config)?;
    let mut inputs = scoring_inputs(&scoring);
    if model_file.is_none() {
        inputs.retain(|(flag, _)| *flag != "--model");
    }
    inputs.push(("--log", args.log.as_path()));
    let to_stdout = is_std_stream(&args.out);
    if !to_stdout {
        refuse_overlaps(&inputs, &[("--out", args.out.as_path())])?;
        refuse_overwriting_a_model("--out", &args.out, "a state table")?;
    }
    let parquet = riskscore_eval::parquet_io::is_parquet(&args.out);
    let mut file = if to_stdout {
        None
    } else {
        Some(AtomicFile::create(&args.out).map_err(super::setup::creating(&args.out))?)
    };
    let sink: Box<dyn Write + Send + '_> = match file.as_mut() {
        Some(f) => Box::new(f),
        None => Box::new(std::io::BufWriter::new(std::io::stdout())),
    };
    let mut table = StatesWriter::new(sink, parquet, model_file.is_some());
    let mut table_error = None;
    let mut problems = ProblemPrinter::new(args.scoring.max_problems);
    problems.skip_lost = true;
    problems.log = Some(crate::logfile::line_name(&args.log));
    let mut losses = FrameLosses::default();
    let mut handle = |o: Output| {
        if let Output::Scored(u) = &o {
            if table_error.is_none() {
                if let Err(e) = table.push(u) {
                    table_error = Some(e);
                }
            }
        }
        problems.handle(&o);
        losses.handle(&o);
    };
    let mut feed = LogFeed::new(args.reorder.merge_wait_ms);
    let report = logfile::for_each_frame(&args.log, |line_no, rec| {
        feed.push(&mut engine, line_no as u64, rec, &mut handle);
    })
    .map_err(|cause| InputError::Read {
        path: logfile::describe(&args.log),
        cause,
    })?;
    feed.finish(&mut engine, &mut handle);
    let out_path = (!to_stdout).then_some(args.out.as_path());
    let columnar = |e: riskscore_eval::parquet_io::ColumnarError| {
        writing("--out", out_path)(std::io::Error::other(e.to_string()))
    };
    if let Some(e) = table_error {
        return Err(columnar(e));
    }
    let rows = table.finish().map_err(columnar)?;
    eprintln!(
        "decode: {} lines; {} state rows to {}; {}",
        report.lines,
        rows,
        display_out(&args.out),
        summary(engine.stats())
    );
    if problems.suppressed > 0 {
        eprintln!(
            "decode: {} more per-frame problems not printed",
            problems.suppressed
        );
    }
    problems.sanity.print("decode");
    // The reasons first: a log nothing could be read from says why, line by line.
    losses::print_lost(&args.log, &report, &losses);
    refuse_empty_log(&args.log, &report, "scored")?;
    refuse_stuck_timestamps(&args.log, &report, engine.stats())?;
    refuse_nothing_scored(engine.stats(), "decode", report.bad_lines())?;
    losses::verdict(&args.log, &report, &losses, args.loss.max_lost)?;
    if let Some(f) = file {
        f.commit().map_err(writing("--out", out_path))?;
    }
    Ok(())
}

fn display_out(out: &Path) -> String {
    if is_std_stream(out) {
        "stdout".into()
    } else {
        out.display().to_string()
    }
}

/// Without `--model` the engine scores with an empty model (score 0, never warns): the states
/// are exactly those a real model would see.
fn no_model() -> Model<'static> {
    Model::Msra(MsraModel {
        terms: BoundedVec::new(),
        gssm: None,
    })
}

/// The engine configuration without a model: a threshold no empty model reaches.
fn states_only_config(scoring: &super::ScoringArgs) -> EngineConfig {
    EngineConfig {
        threshold: 1.0,
        urgent: None,
        hysteresis: scoring.hysteresis,
        min_on_us: scoring.min_on_ms * 1000,
        stale_us: scoring.stale_ms * 1000,
        latch: false,
    }
}
