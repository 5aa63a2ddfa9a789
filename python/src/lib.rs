//! `riskscore._riskscore`: the extension module under the `riskscore` Python package.
//!
//! Thin by design: every number comes from `riskscore_eval::arrow_kernel` (surrogates, features,
//! model scores through scorer-core), `riskscore_data` (event folders) and `riskscore_eval`
//! (evaluation). This crate only moves Arrow data across the C data interface, splits large
//! tables over the cores with the GIL released, and turns Rust errors into the Python exceptions
//! of `riskscore.errors`. The Python-facing API, its docstrings and the input conversions
//! (pandas, polars, dicts of numpy arrays) live in `python/riskscore/`; see docs/python.md.
use pyo3::prelude::*;

mod errors;
mod evaluate;
mod events;
mod model;
mod pool;
mod tables;

#[pymodule]
fn _riskscore(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(tables::ssm, m)?)?;
    m.add_function(wrap_pyfunction!(tables::computed_columns, m)?)?;
    m.add_function(wrap_pyfunction!(events::read_events, m)?)?;
    m.add_function(wrap_pyfunction!(events::write_events, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::evaluate, m)?)?;
    m.add_class::<model::Model>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
