//! The interface a trainable risk-score parameterisation offers the comparison trainer (its own
//! module so that the parameterisations do not depend on the trainer that uses them).
use candle_core::{Tensor, Var};

use crate::comparisons::ObservationTable;

/// A trainable risk-score parameterisation.
pub trait RiskModel {
    /// Short name for logs ("DRL", "MSRA", ...).
    fn name(&self) -> &str;
    /// Width of one observation's input row.
    fn input_width(&self) -> usize;
    /// Input rows of every observation of the table, row-major (`table.len() * input_width()`).
    fn encode(&self, table: &ObservationTable) -> Vec<f32>;
    /// Scores `[n]` of a batch of input rows `[n, input_width]`.
    fn forward(&self, inputs: &Tensor) -> candle_core::Result<Tensor>;
    /// The trainable variables.
    fn vars(&self) -> Vec<Var>;
}
