//! Rust failures as the exceptions of `riskscore.errors` (defined in Python so that they can
//! also be `ValueError`s and carry the row and column as attributes).
use pyo3::prelude::*;
use riskscore_data::ssm_csv::RowError;

/// A failure computed with the GIL released, raised once it is held again.
#[derive(Debug)]
pub enum Failure {
    /// A missing, ambiguous or non-numeric column.
    Column(String),
    /// A model blob that cannot be read or decoded.
    Model(String),
    /// An event folder that cannot be read, written or evaluated.
    Events(String),
    /// A file that exists and would be replaced.
    Exists(String),
    /// The operating system refused the worker threads.
    Threads(String),
}

impl Failure {
    pub fn into_py(self, py: Python<'_>) -> PyErr {
        let (class, message) = match self {
            Failure::Column(m) => ("ColumnError", m),
            Failure::Model(m) => ("ModelError", m),
            Failure::Events(m) => ("EventsError", m),
            Failure::Exists(m) => {
                return pyo3::exceptions::PyFileExistsError::new_err(m);
            }
            Failure::Threads(m) => return pyo3::exceptions::PyOSError::new_err(m),
        };
        raise(py, class, &message)
    }
}

/// An instance of `riskscore.errors.<class>` with `message`, as a `PyErr`.
fn raise(py: Python<'_>, class: &str, message: &str) -> PyErr {
    let made = py
        .import("riskscore.errors")
        .and_then(|m| m.getattr(class))
        .and_then(|c| c.call1((message,)));
    match made {
        Ok(instance) => PyErr::from_value(instance),
        Err(e) => e,
    }
}

/// The bad rows of a table as `(row, column, problem)` tuples: `row` 0-based (the kernels count
/// lines from 1), `column` the input column's name when one is to blame.
pub type BadRow = (u64, Option<String>, String);

pub fn bad_rows(errors: impl IntoIterator<Item = RowError>) -> Vec<BadRow> {
    errors
        .into_iter()
        .map(|e| (e.line.saturating_sub(1), e.column, e.problem.to_string()))
        .collect()
}

/// `e` and its causes, `: `-separated (a cause its message already shows is not repeated), as
/// `riskctl` prints them: `model file m.rsk: cannot read: No such file or directory (os error 2)`.
pub fn with_causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let shown = c.to_string();
        if !text.contains(&shown) {
            text = format!("{text}: {shown}");
        }
        cause = c.source();
    }
    text
}
