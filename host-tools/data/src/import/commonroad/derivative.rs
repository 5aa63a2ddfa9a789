//! The time derivative of a recorded speed, shared by the importer's acceleration fill-in and
//! its smoothing.

/// The time derivative of a speed at state `i` of `n` (`at(k)` gives state `k`'s step and speed,
/// `dt` s per step): the central difference between its neighbours, one-sided at the ends.
/// `n` must be at least 2.
pub(super) fn speed_derivative(
    n: usize,
    i: usize,
    dt: f64,
    at: impl Fn(usize) -> (i64, f64),
) -> f64 {
    let (a, b) = match i {
        0 => (0, 1),
        i if i + 1 == n => (i - 1, i),
        i => (i - 1, i + 1),
    };
    let ((step_a, speed_a), (step_b, speed_b)) = (at(a), at(b));
    (speed_b - speed_a) / ((step_b - step_a) as f64 * dt)
}
