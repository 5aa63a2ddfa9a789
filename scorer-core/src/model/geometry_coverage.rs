//! The geometry-coverage record (tag 4 of a version-2 blob): which geometry cells
//! ([`crate::geometry_cell`]) the model's training sequences reached. Part of the training
//! domain: an observation whose inputs are all inside their ranges but whose cell is not covered is
//! outside ([`crate::domain`]), reported as input [`GEOMETRY_INPUT`].
//!
//! Only the blobs of a network carry it (DRL, GSSM:
//! [`Model::runs_a_network`](super::Model::runs_a_network); the cell is read off the DRL inputs of
//! the pair whatever the model reads), and only beside a training-domain record (tag 2). A build
//! that does not know tag 4 skips it and guards by the ranges alone.
//!
//! Body (postcard): `scheme: u8` (the cell scheme, [`GEOMETRY_CELL_SCHEME`]), then `cells` as a
//! byte string of [`COVERAGE_BYTES`] bytes: cell `c` is covered when bit `c % 8` of byte `c / 8` is
//! set. Borrowed from the blob like the ranges: no copy on the ECU. Byte layout:
//! `docs/model-format.md`.
use serde::{Deserialize, Serialize};

use super::ModelError;
use crate::geometry_cell::{GEOMETRY_CELLS, GEOMETRY_CELL_SCHEME};

/// Record tag of the [`GeometryCoverage`].
pub const GEOMETRY_COVERAGE_TAG: u8 = 4;
/// Bytes of the cell bit set.
pub const COVERAGE_BYTES: usize = GEOMETRY_CELLS / 8;
/// The input index [`TrainingDomain::first_outside`](super::TrainingDomain::first_outside)
/// reports for an observation in an uncovered cell (one past the 13 inputs).
pub const GEOMETRY_INPUT: u8 = 13;
/// What the tools call [`GEOMETRY_INPUT`].
pub const GEOMETRY_INPUT_NAME: &str = "geometry";

/// The covered geometry cells of a training domain.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeometryCoverage<'a> {
    /// The cell scheme the bits are indexed by.
    pub scheme: u8,
    /// [`COVERAGE_BYTES`] bytes, one bit per cell.
    #[serde(borrow)]
    pub cells: &'a [u8],
}

impl<'a> GeometryCoverage<'a> {
    /// Coverage of this build's cell scheme over the bit set `cells`.
    pub fn new(cells: &'a [u8]) -> Self {
        Self {
            scheme: GEOMETRY_CELL_SCHEME,
            cells,
        }
    }

    /// The record of `body`, its postcard form `scheme, length, cells` read directly (a varint
    /// length below 128 is one byte; a longer string is refused by [`Self::validate`] anyway):
    /// a body of another shape reads as cells of the wrong length, for `validate` to name.
    pub(super) fn from_body(body: &'a [u8]) -> Self {
        match body {
            [scheme, len, cells @ ..] if usize::from(*len) == cells.len() => Self {
                scheme: *scheme,
                cells,
            },
            _ => Self {
                scheme: body.first().copied().unwrap_or(GEOMETRY_CELL_SCHEME),
                cells: &[],
            },
        }
    }

    /// True when `cell` is covered (a cell past the bit set is not).
    pub fn covers(&self, cell: u8) -> bool {
        self.cells
            .get(usize::from(cell / 8))
            .is_some_and(|b| b >> (cell % 8) & 1 == 1)
    }

    /// Number of covered cells.
    pub fn covered(&self) -> u32 {
        self.cells.iter().map(|b| b.count_ones()).sum()
    }

    /// This build's scheme and a whole bit set.
    pub fn validate(&self) -> Result<(), ModelError> {
        if self.scheme != GEOMETRY_CELL_SCHEME {
            return Err(ModelError::BadRecord {
                field: "geometry_coverage.scheme",
                reason: "a cell scheme this build does not compute",
            });
        }
        if self.cells.len() != COVERAGE_BYTES {
            return Err(ModelError::DimensionMismatch {
                field: "geometry_coverage.cells",
                index: 0,
                expected: COVERAGE_BYTES,
                found: self.cells.len(),
            });
        }
        Ok(())
    }
}
