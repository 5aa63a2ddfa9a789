//! `riskctl plot`: a picture of one event (paths, boxes, every method's risk and first warning).
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use riskscore_data::events::{stream_events, Event, EventsError};
use riskscore_eval::event_figure::EventPicture;
use riskscore_eval::model_files::{named_models, ModelFile};
use riskscore_eval::plots::ImageFormat;
use riskscore_eval::Method;

const ABOUT_PLOT: &str = "\
The figure has two parts. Above: a bird's-eye view (world frame, one scale on both axes) of the
ego's path (dark) and the partner's (red), each starting at a dot, with both boxes outlined at
the first warning and filled at the endpoint (impact or safety-critical moment; a safe event's
last frame). Below: one strip per method, its risk R over time exactly as `riskctl evaluate`
scores it (models through scorer-core, DRL int8 as on the ECU; the baselines as R = -TTC2D,
-TAdv, EI), with the threshold (dashed), the endpoint (black) and the first warning (the first
frame with R >= threshold up to the endpoint; a vertical line and a triangle). Gaps are frames
where the method sees no conflict (an infinite TTC2D, say). Each method has the colour and line
style it has in every figure of `riskctl demo` and `evaluate --out`.

The warning on the map is the first method's that warns, in the order given (models first).
Thresholds: by default each model at its own default threshold (`riskctl inspect-model` prints it)
and the baselines at none; --threshold works as in `riskctl evaluate` (a baseline's threshold is in
its R units: --threshold TTC2D=-1.5 warns at TTC2D <= 1.5 s).

Examples:
  riskctl plot --events data/ngsim-us101-safe --event 'USA_US101-10_1_T-1/529-558@0#0' \\
               --model models/drl-default.rsk --out event.svg
  riskctl simulate --out sim --seed 7
  riskctl plot --events sim --event 000003 --model models/msra-default.rsk \\
               --threshold TTC2D=-1.5 --out 000003.png";

/// Draw one event: both road users' paths, and every method's risk over time.
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_PLOT)]
pub struct Args {
    /// Event folder (events.csv + frames.csv).
    #[arg(long, value_name = "DIR")]
    events: PathBuf,
    /// The event to draw (its `event_id`).
    #[arg(long, value_name = "ID")]
    event: String,
    /// Model blob whose risk is drawn (repeatable; `NAME=FILE` names it). The baselines TTC2D,
    /// TAdv and EI are always drawn.
    #[arg(long = "model", value_name = "[NAME=]FILE")]
    models: Vec<String>,
    /// Threshold per method: `T` (every model), `NAME=T`, `default` or `none` (as in `evaluate`).
    #[arg(
        long = "threshold",
        value_name = "T|NAME=T|default|none",
        allow_negative_numbers = true
    )]
    thresholds: Vec<String>,
    /// Output image: `.svg` or `.png`. Written under a temporary name and renamed into place;
    /// an input file, and any model blob or training checkpoint, is refused.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Some(format) = ImageFormat::of_path(&args.out) else {
        bail!(
            "--out {}: the file name must end in .svg or .png",
            args.out.display()
        );
    };
    let files = ModelFile::read_all(&args.models)?;
    super::output::refuse_overwriting_inputs(&files, &args.events, &[("--out", &args.out)])?;
    super::output::refuse_overwriting_a_model("--out", &args.out, "an image")?;
    let mut methods: Vec<Method<'_>> = named_models(&files)?;
    let baselines = Method::baselines_for(&methods);
    methods.extend(baselines);
    let thresholds = super::evaluate::operating_thresholds(&args.thresholds, &files, &methods)?;
    let event = find_event(&args.events, &args.event)?;
    let frames = event.frames.len();
    let picture = EventPicture::score(event, &methods, &thresholds);
    let bytes = picture.render(format)?;
    super::output::write_file_atomically(&args.out, &bytes)?;
    eprintln!(
        "riskctl: wrote {} ({} bytes): event {}, {frames} frames, {} methods",
        args.out.display(),
        bytes.len(),
        args.event,
        picture.methods.len()
    );
    for m in &picture.methods {
        match (m.threshold, m.first_warning) {
            (Some(t), Some(w)) => {
                eprintln!("  {}: threshold {t}, first warning at {w:.2} s", m.name)
            }
            (Some(t), None) => eprintln!("  {}: threshold {t}, no warning", m.name),
            (None, _) => {}
        }
    }
    Ok(())
}

/// Reads `dir` one event at a time and keeps only `id`; a problem in that event's rows, or an id
/// the folder does not have, is an error that names it.
fn find_event(dir: &Path, id: &str) -> anyhow::Result<Event> {
    let mut found = None;
    let mut count = 0usize;
    let mut first_ids: Vec<String> = Vec::new();
    let issues = stream_events::<EventsError>(dir, false, |_, event| {
        count += 1;
        if first_ids.len() < 3 {
            first_ids.push(event.id.clone());
        }
        if event.id == id {
            found = Some(event);
        }
        Ok(())
    })
    .or_else(|e| match e {
        // Frames not grouped by event: read the folder whole.
        EventsError::NotStreamable { .. } => {
            let (set, issues) = riskscore_data::events::load_events(dir)?;
            count = set.len();
            first_ids = set.iter().take(3).map(|e| e.id.clone()).collect();
            found = set.get(id).cloned();
            Ok(issues)
        }
        e => Err(e),
    })
    .with_context(|| format!("event folder {}", dir.display()))?;
    let (notes, own): (Vec<_>, Vec<_>) = issues
        .iter()
        .filter(|i| i.event_id.as_deref() == Some(id))
        .partition(|i| i.problem.is_note());
    // A note keeps its event (a hole in the frames, speeds in other units): drawing it is how one
    // looks at what the note says.
    for note in notes {
        eprintln!("riskctl: warning: {note}");
    }
    if let Some(issue) = own.first() {
        bail!(
            "event {id:?} cannot be drawn: {issue}{}",
            if own.len() > 1 {
                format!(" (and {} more problems)", own.len() - 1)
            } else {
                String::new()
            }
        );
    }
    found.with_context(|| {
        format!(
            "{}: no event {id:?} among its {count} valid events (the first: {})",
            dir.join(riskscore_data::events::EVENTS_FILE).display(),
            first_ids.join(", ")
        )
    })
}
