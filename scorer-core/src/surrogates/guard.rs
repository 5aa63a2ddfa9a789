//! The reference implementations' guard against dividing by a near-zero speed difference.
/// The reference's guard against division by zero: values in `[0, 1e-6)` become `1e-6`, values in
/// `(-1e-6, 0)` become `-1e-6` (so `-0.0` becomes `+1e-6`).
pub(crate) fn clamp_away_from_zero(x: f32) -> f32 {
    const EPS: f32 = 1e-6;
    if (0.0..EPS).contains(&x) {
        EPS
    } else if x < 0.0 && x > -EPS {
        -EPS
    } else {
        x
    }
}
