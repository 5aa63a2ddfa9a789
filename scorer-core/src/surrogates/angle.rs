//! "Are two directions within a few degrees of parallel?" without the arctangent when the answer is
//! clear.
//!
//! TAdv and EI compare the angle `|atan2(cross, dot)|` of two directions with a small limit (and
//! its supplement). Away from the limit the ratio `|cross| / |dot|` (the tangent of the angle
//! between the two lines) settles it: below `tan(limit)` by a few percent the lines are within the
//! limit, above it by a few percent they are not, while `atan2f` is within a few ulps. Only pairs
//! whose ratio falls in that band (or odd values: zero, subnormal, infinite, NaN) pay for
//! `atan2f`, and they get exactly the reference's answer, so the result is the same for every
//! input.

/// Tangent bounds around an angle limit: `below < tan(limit) < above`, both a few percent away
/// from it (far beyond `atan2f`'s error and the rounding of one product).
#[derive(Clone, Copy)]
pub(super) struct TangentBand {
    pub(super) below: f32,
    pub(super) above: f32,
}

/// Smallest `|dot|` for which `band * |dot|` is computed with full relative precision (a normal
/// number): subnormal products could round by a whole unit of their grid.
const MIN_DOT: f32 = 1e-30;

/// Whether the line angle of `(dot, cross)` (the angle between the two lines, in `[0, pi/2]`) is
/// clearly within the limit (`Some(true)`), clearly outside (`Some(false)`), or too close to call
/// or odd input (`None`: ask `atan2f`).
pub(super) fn line_angle_within(band: TangentBand, cross: f32, dot: f32) -> Option<bool> {
    let (cross, dot) = (libm::fabsf(cross), libm::fabsf(dot));
    if !(cross.is_finite() && dot.is_finite() && dot >= MIN_DOT) {
        return None;
    }
    if cross <= band.below * dot {
        Some(true)
    } else if cross >= band.above * dot {
        Some(false)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every direction on a fine grid (and near the band edges): a decided answer equals the
    /// arctangent's.
    #[test]
    fn decided_answers_equal_the_arctangent() {
        let limit = core::f32::consts::PI / 60.0;
        let band = TangentBand {
            below: 0.0512,
            above: 0.0536,
        };
        let mut decided = 0;
        for k in 0..200_000 {
            let angle = -4.0 + 8.0 * k as f32 / 200_000.0;
            for scale in [1e-20f32, 1e-3, 1.0, 37.0, 1e20] {
                let (cross, dot) = (libm::sinf(angle) * scale, libm::cosf(angle) * scale);
                let exact = libm::atan2f(cross, dot).abs();
                let within = exact < limit || exact > core::f32::consts::PI - limit;
                if let Some(fast) = line_angle_within(band, cross, dot) {
                    decided += 1;
                    assert_eq!(fast, within, "angle {angle} scale {scale}");
                }
            }
        }
        assert!(
            decided > 900_000,
            "the band decides most directions ({decided})"
        );
        for odd in [f32::NAN, f32::INFINITY] {
            assert_eq!(line_angle_within(band, 1.0, odd), None);
            assert_eq!(line_angle_within(band, odd, 1.0), None);
        }
        // A subnormal `dot` would round `band * dot` by a whole grid unit; zero likewise asks.
        assert_eq!(line_angle_within(band, 1e-44, 3e-43), None);
        assert_eq!(line_angle_within(band, 1.0, 0.0), None);
    }
}
