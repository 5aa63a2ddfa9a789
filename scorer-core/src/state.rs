//! The kinematic state of one road user, as every other module consumes it.

/// One road user at one instant. SI units, world frame, position of the centre of its box.
///
/// `(hx, hy)` is the unit heading vector (the box's long axis; every consumer normalises it, so a
/// non-unit vector gives the same numbers); `(vx, vy)` the velocity over ground in the same frame
/// (m/s), which need not be parallel to the heading (side slip, reversing, noisy trackers). `acc`
/// is the longitudinal acceleration along the heading (m/s^2); `length` and `width` the box (m).
///
/// # Check states before scoring
///
/// The core is total: it scores any state (NaN, infinities, a zero heading, a negative size) to a
/// finite number without panicking. But a state without a usable box reads as "no conflict" to
/// the box-based surrogates and inputs, so its score is not a risk: a stopped car close ahead
/// whose tracker lost the heading scores as harmless. The C ABI refuses such states
/// (`RISKSCORE_STATUS_NON_FINITE_STATE`, `RISKSCORE_STATUS_INVALID_INPUT`); firmware that calls
/// the core from Rust should make the same check and not score the pair:
///
/// ```
/// use scorer_core::geometry::unit_heading;
/// use scorer_core::{decode_blob, VehicleState};
///
/// /// What the C ABI accepts: finite, a heading it can normalise, a size >= 0 (0 is a point).
/// fn scorable(s: &VehicleState) -> bool {
///     s.is_finite() && unit_heading(s).is_some() && s.length >= 0.0 && s.width >= 0.0
/// }
///
/// let blob = decode_blob(include_bytes!("../../models/drl-default.rsk")).unwrap();
/// let car = |x: f32, vx: f32, hx: f32| VehicleState {
///     x, y: 0.0, vx, vy: 0.0, hx, hy: 0.0, acc: 0.0, length: 4.5, width: 1.8,
/// };
/// let ego = car(0.0, 20.0, 1.0);
/// let stopped_ahead = car(15.0, 0.0, 1.0); // 10.5 m gap, 0.5 s to impact
/// let heading_lost = car(15.0, 0.0, 0.0);
/// let threshold = blob.default_threshold();
///
/// assert!(scorable(&stopped_ahead));
/// assert!(blob.score_pair_guarded(&ego, &stopped_ahead).score >= threshold);
/// // The same car without a heading: a finite score far below the threshold.
/// assert!(!scorable(&heading_lost));
/// assert!(blob.score_pair_guarded(&ego, &heading_lost).score < threshold);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct VehicleState {
    pub x: f32,
    pub y: f32,
    pub vx: f32,
    pub vy: f32,
    pub hx: f32,
    pub hy: f32,
    pub acc: f32,
    pub length: f32,
    pub width: f32,
}

impl VehicleState {
    /// Speed `|(vx, vy)|`.
    pub fn speed(&self) -> f32 {
        crate::vec2::Vec2::new(self.vx, self.vy).norm()
    }

    /// True when every field is finite.
    pub fn is_finite(&self) -> bool {
        [
            self.x,
            self.y,
            self.vx,
            self.vy,
            self.hx,
            self.hy,
            self.acc,
            self.length,
            self.width,
        ]
        .iter()
        .all(|v| v.is_finite())
    }
}
