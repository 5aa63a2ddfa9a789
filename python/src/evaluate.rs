//! `riskscore.evaluate`: the numbers of `riskctl evaluate --json` for an event folder.
use std::collections::HashMap;
use std::path::PathBuf;

use pyo3::prelude::*;
use riskscore_data::events::PrepareConfig;
use riskscore_eval::model_files::{named_models, ModelFile};
use riskscore_eval::streaming::{evaluate_folder_gathering, BadRowsWording, FolderRefusal, Gather};
use riskscore_eval::Method;

use crate::errors::{with_causes, Failure};
use crate::events::split_issues;

/// What one row's threshold is set to (from the Python `thresholds` argument).
#[derive(Clone, Copy, Debug, FromPyObject)]
pub enum Choice {
    /// A threshold value.
    Value(f32),
    /// `"default"` (the model's own) or `"none"` (no operating point).
    Word(Word),
}

#[derive(Clone, Copy, Debug)]
pub enum Word {
    Default,
    None,
}

impl<'a, 'py> FromPyObject<'a, 'py> for Word {
    type Error = PyErr;
    fn extract(value: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        match value.extract::<String>()?.as_str() {
            "default" => Ok(Word::Default),
            "none" => Ok(Word::None),
            other => Err(pyo3::exceptions::PyValueError::new_err(format!(
                "threshold {other:?}: expected a number, \"default\" or \"none\""
            ))),
        }
    }
}

/// The threshold of each row (in `methods` order): each model row at its default, then `all`
/// applied (a value or `default` to the model rows, `none` to every row), then `by_name`.
fn thresholds(
    files: &[ModelFile],
    methods: &[Method<'_>],
    all: Option<Choice>,
    by_name: &HashMap<String, Choice>,
) -> Result<Vec<Option<f32>>, Failure> {
    let defaults = files
        .iter()
        .map(|f| {
            f.default_threshold()
                .map_err(|e| Failure::Model(e.to_string()))
        })
        .collect::<Result<Vec<f32>, _>>()?;
    let default_of = |row: usize| defaults.get(row).copied();
    let mut chosen: Vec<Option<f32>> = (0..methods.len()).map(default_of).collect();
    match all {
        Some(Choice::Word(Word::None)) => chosen.iter_mut().for_each(|t| *t = None),
        Some(Choice::Value(t)) => chosen
            .iter_mut()
            .take(files.len())
            .for_each(|s| *s = Some(t)),
        Some(Choice::Word(Word::Default)) | None => {}
    }
    for (name, choice) in by_name {
        let Some(row) = methods.iter().position(|m| &m.name == name) else {
            let names: Vec<&str> = methods.iter().map(|m| m.name.as_str()).collect();
            return Err(Failure::Model(format!(
                "thresholds: no row named {name:?} (rows: {})",
                names.join(", ")
            )));
        };
        chosen[row] = match choice {
            Choice::Value(t) => Some(*t),
            Choice::Word(Word::None) => None,
            Choice::Word(Word::Default) => Some(default_of(row).ok_or_else(|| {
                Failure::Model(format!(
                    "thresholds: {name} is a baseline and has no default threshold"
                ))
            })?),
        };
    }
    if let Some(bad) = chosen.iter().flatten().find(|t| !t.is_finite()) {
        return Err(Failure::Model(format!("threshold {bad} is not finite")));
    }
    Ok(chosen)
}

/// What [`evaluate`] hands to Python: the JSON text, the problems, the notes, the problem count
/// and the events without a sequence.
type Evaluated = (String, Vec<String>, Vec<String>, u64, Vec<String>);

/// The `riskctl evaluate --json` object as JSON text, the folder's problems and notes (one line
/// each), how many problems there are, and the events that yield no sequence under the
/// preparation rules (one line each, as `riskctl evaluate` lists them on stderr: they are left out
/// of the metrics). `models` are `[NAME=]FILE` specs as on the command line.
#[pyfunction]
#[pyo3(signature = (events, models, threshold_all = None, thresholds_by_name = HashMap::new(), skip_bad_events = false))]
pub fn evaluate(
    py: Python<'_>,
    events: PathBuf,
    models: Vec<String>,
    threshold_all: Option<Choice>,
    thresholds_by_name: HashMap<String, Choice>,
    skip_bad_events: bool,
) -> PyResult<Evaluated> {
    let evaluated = py.detach(|| -> Result<_, Failure> {
        let files = ModelFile::read_all(&models).map_err(|e| Failure::Model(with_causes(&e)))?;
        let mut methods = named_models(&files).map_err(|e| Failure::Model(e.to_string()))?;
        let baselines = Method::baselines_for(&methods);
        methods.extend(baselines);
        let chosen = thresholds(&files, &methods, threshold_all, &thresholds_by_name)?;
        let workers = std::thread::available_parallelism().map_or(1, usize::from);
        let gather = Gather {
            trajectories: None,
            thresholds: &chosen,
        };
        let where_ = || format!("event folder {}", events.display());
        let folder =
            evaluate_folder_gathering(&events, &methods, PrepareConfig::default(), workers, gather)
                .map_err(|e| Failure::Events(format!("{}: {}", where_(), with_causes(&e))))?;
        let (problems, notes, count) = split_issues(&folder.load_issues);
        if let Err(refusal) = folder.check(skip_bad_events) {
            // riskctl prints the problems first; here they follow the message.
            let why = match refusal {
                FolderRefusal::BadRows { valid_events } => FolderRefusal::bad_rows_message(
                    valid_events,
                    BadRowsWording {
                        listed: "below",
                        left_out_of: "metrics",
                        skip: Some("skip_bad_events=True"),
                    },
                ),
                other => other.to_string(),
            };
            let mut message = format!("{}: {why}", where_());
            if !problems.is_empty() {
                message = format!("{message}\n  {}", problems.join("\n  "));
            }
            if !notes.is_empty() {
                message = format!(
                    "{message}\nnotes (they leave nothing out):\n  {}",
                    notes.join("\n  ")
                );
            }
            return Err(Failure::Events(message));
        }
        let json = folder
            .to_json_text()
            .map_err(|e| Failure::Events(e.to_string()))?;
        let unprepared = folder
            .prepare_issues
            .iter()
            .map(|i| i.to_string())
            .collect();
        Ok((json, problems, notes, count, unprepared))
    });
    evaluated.map_err(|f| f.into_py(py))
}
