//! The geometry cell of an observation (scheme [`GEOMETRY_CELL_SCHEME`]): where the partner is
//! around the ego, which way it heads relative to the ego, and how far its box is; read off the
//! DRL inputs (encoding 3) with comparisons only.
//!
//! Why: every DRL input can lie inside its trained range while their combination was never
//! trained on (a partner crossing the ego's path 60 m ahead; a partner passing across a stopped
//! ego). A network extrapolates there as freely as outside the ranges. The training-domain
//! guard therefore also checks the cell against the cells the training sequences reached
//! ([`GeometryCoverage`](crate::model::GeometryCoverage), record tag 4; `docs/domain-guard.md`).
//!
//! | part     | from inputs                    | values                                               |
//! |----------|--------------------------------|------------------------------------------------------|
//! | bearing  | `ahead` (11), `right` (12)     | octant of the partner centre, clockwise from the ego's heading: 0 = ahead to ahead-right 45 deg, 2 = right to behind-right, ... |
//! | heading  | `cos_psi` (6), `sin_psi` (7)   | octant of the partner heading, counter-clockwise from the ego's: 0 = same to 45 deg left, 2 = crossing from right to left, turning towards oncoming, ... |
//! | distance | `log_gap` (8)                  | box gap below [`NEAR_GAP`] m: 0, below [`MID_GAP`] m: 1, else 2 |
//!
//! `cell = (distance * 8 + bearing) * 8 + heading`, in `0..GEOMETRY_CELLS`. Octant boundaries lie on
//! the axes and the diagonals; an octant is read off three comparisons (`s < 0`, `c < 0`,
//! `|s| > |c|` for the direction `(c, s)`), which also settles a direction on a boundary. `slog`
//! is odd and increasing, so the signs and magnitude comparisons of `ahead` and `right` are those
//! of the metres they encode.
use crate::encoding::{DrlInputs, AHEAD, COS_PSI, LOG_GAP, RIGHT, SIN_PSI};

/// The cell scheme this build computes (the coverage record's scheme byte).
pub const GEOMETRY_CELL_SCHEME: u8 = 1;
/// Number of cells: 3 distance bands x 8 bearings x 8 headings.
pub const GEOMETRY_CELLS: usize = 192;
/// Box gap (m) below which a partner is near.
pub const NEAR_GAP: f32 = 10.0;
/// Box gap (m) below which a partner is at middle distance.
pub const MID_GAP: f32 = 35.0;

/// `ln(0.5 + NEAR_GAP)` and `ln(0.5 + MID_GAP)` as `log_gap` encodes them (rounded to f32).
const LOG_NEAR_GAP: f32 = 2.351_375_3;
const LOG_MID_GAP: f32 = 3.569_532_7;

/// The geometry cell of DRL inputs `x` (encoding 3), in `0..GEOMETRY_CELLS`.
pub fn geometry_cell(x: &DrlInputs) -> u8 {
    let at = |i: usize| x.get(i).copied().unwrap_or(0.0);
    let gap = at(LOG_GAP);
    let distance = if gap < LOG_NEAR_GAP {
        0
    } else if gap < LOG_MID_GAP {
        1
    } else {
        2
    };
    let bearing = octant(at(AHEAD), at(RIGHT));
    let heading = octant(at(COS_PSI), at(SIN_PSI));
    (distance * 8 + bearing) * 8 + heading
}

/// The octant `0..8` of the direction `(c, s)` (the angle from `+c` towards `+s`) from three
/// comparisons: `s < 0`, `c < 0` and `|s| > |c|` (a table, not branches: ECU flash). NaN and the
/// zero vector read as octant 0.
fn octant(c: f32, s: f32) -> u8 {
    const BY_SIGNS_AND_STEEPNESS: [u8; 8] = [0, 1, 3, 2, 7, 6, 4, 5];
    let index = usize::from(s < 0.0) * 4
        + usize::from(c < 0.0) * 2
        + usize::from(libm::fabsf(s) > libm::fabsf(c));
    BY_SIGNS_AND_STEEPNESS.get(index).copied().unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octants_go_round_in_eighths() {
        let deg = |d: f32| {
            let r = d.to_radians();
            octant(libm::cosf(r), libm::sinf(r))
        };
        for k in 0..8u8 {
            let centre = 22.5 + 45.0 * f32::from(k);
            assert_eq!(deg(centre), k, "{centre} deg");
        }
        // On a boundary: the steeper octant only when `|s| > |c|`, the negative side only for
        // a negative component.
        assert_eq!(octant(1.0, 0.0), 0);
        assert_eq!(octant(1.0, 1.0), 0);
        assert_eq!(octant(0.0, 1.0), 1);
        assert_eq!(octant(-1.0, 0.0), 3);
        assert_eq!(octant(-1.0, 1.0), 3);
        assert_eq!(octant(0.0, -1.0), 6);
        assert_eq!(octant(-1.0, -1.0), 4);
        assert_eq!(octant(0.0, 0.0), 0);
        assert_eq!(octant(f32::NAN, f32::NAN), 0);
    }

    #[test]
    fn the_gap_bands_are_the_encoded_log_gaps() {
        assert_eq!(LOG_NEAR_GAP, crate::encoding::log_gap(NEAR_GAP));
        assert_eq!(LOG_MID_GAP, crate::encoding::log_gap(MID_GAP));
    }
}
