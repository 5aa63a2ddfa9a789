//! The kinematic state of one road user, as every other module consumes it.

/// One road user at one instant. SI units, world frame, position of the centre of its box.
///
/// `(hx, hy)` is the unit heading vector (the box's long axis); `(vx, vy)` the velocity, which need
/// not be parallel to the heading (side slip, reversing, noisy trackers). `acc` is the longitudinal
/// acceleration along the heading (m/s^2).
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
