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
    /// World-frame x of the centre of the box (m; not the rear axle, not a GPS antenna).
    ///
    /// One fixed right-handed Cartesian frame for ego and partner (e.g. local ENU); only
    /// differences of positions matter. f32 resolves better than 1 cm within 100 km of the origin
    /// but only 0.5 m at a UTM northing (5,400 km): subtract a local origin first. Non-finite: the
    /// state has no box (see "Check states before scoring").
    pub x: f32,
    /// World-frame y of the centre of the box (m); as [`VehicleState::x`].
    pub y: f32,
    /// Velocity over ground along the world x axis (m/s), not relative to the ego.
    ///
    /// Need not be parallel to the heading (side slip, reversing). Any finite value is scored; the
    /// operating domain (`docs/domain.md`) is a speed `|(vx, vy)|` of 0-50 m/s per road user and
    /// up to 30 m/s relative: beyond what a blob's training data covered, its training-domain
    /// guard decides ([`ModelBlob::score_pair_guarded`](crate::ModelBlob::score_pair_guarded)).
    /// Non-finite: no box.
    pub vx: f32,
    /// Velocity over ground along the world y axis (m/s); as [`VehicleState::vx`].
    pub vy: f32,
    /// World-frame x of the heading: the direction the front of the box points (dimensionless).
    ///
    /// `(hx, hy)` is normally a unit vector; any other non-zero finite vector is normalised
    /// ([`unit_heading`](crate::geometry::unit_heading)) and gives the same numbers. A heading, not
    /// an angle: no yaw convention applies; angles derived from it (`psi_sur`, `sin_psi`) are
    /// counter-clockwise positive in the right-handed world frame, and the ego frame of the
    /// features and DRL inputs has `+y` along the ego heading and `+x` to the ego's right. A zero
    /// or non-finite heading: no box (see "Check states before scoring").
    pub hx: f32,
    /// World-frame y of the heading (dimensionless); as [`VehicleState::hx`].
    pub hy: f32,
    /// Longitudinal acceleration along the heading (m/s^2, braking negative).
    ///
    /// No score of this crate reads it: it is carried for the host tools (the safe-sequence rule).
    /// It still counts in [`VehicleState::is_finite`]: a NaN or infinite `acc` makes the whole
    /// state non-finite and so without a box (see "Check states before scoring"; the C ABI refuses
    /// it). Pass `0.0` when unknown.
    pub acc: f32,
    /// Length of the box along the heading, bumper to bumper (m), `>= 0` (0: a point).
    ///
    /// A negative length is not refused here and gives no meaningful score (the box distance
    /// reads its magnitude, the features, TTC2D and EI the signed value); the C ABI refuses it
    /// (`RISKSCORE_STATUS_INVALID_INPUT`). Non-finite: no box.
    pub length: f32,
    /// Width of the box across the heading, without mirrors (m), `>= 0`; as
    /// [`VehicleState::length`].
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
