//! 2-D vector arithmetic in `f32` only (no `f64`, which a Cortex-M4F emulates in software).
/// A 2-D vector (m or m/s).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Vec2 {
    /// x component (m for positions, m/s for velocities, dimensionless for headings), world frame
    /// unless the function that returns the vector says otherwise.
    pub x: f32,
    /// y component, in the same unit and frame as [`Vec2::x`].
    pub y: f32,
}

impl Vec2 {
    /// The vector `(x, y)`.
    pub const fn new(x: f32, y: f32) -> Self {
        Self { x, y }
    }
    /// Dot product `x * o.x + y * o.y` (unit: the product of the two vectors' units). No
    /// overflow guard: infinite or NaN as IEEE arithmetic gives it.
    pub fn dot(self, o: Vec2) -> f32 {
        self.x * o.x + self.y * o.y
    }
    /// z component of the 3-D cross product `self x o` (positive when `o` is counter-clockwise).
    pub fn cross(self, o: Vec2) -> f32 {
        self.x * o.y - self.y * o.x
    }
    /// `|self|` in `f32` only: one `sqrtf` of the squared norm when that is a normal number, else
    /// (zero, subnormal or overflowing squares) the components are first scaled by the larger
    /// one. Within an ulp or so of `hypot`; `libm::hypotf` itself works in `f64`, which a
    /// single-precision FPU (Cortex-M4F) emulates in software, in time and in flash. Infinite
    /// when a component is, NaN when one is NaN and the other finite.
    pub fn norm(self) -> f32 {
        let n2 = self.norm2();
        if n2.is_normal() {
            return libm::sqrtf(n2);
        }
        let m = libm::fabsf(self.x).max(libm::fabsf(self.y));
        if m == 0.0 || !m.is_finite() {
            return m;
        }
        let (x, y) = (self.x / m, self.y / m);
        m * libm::sqrtf(x * x + y * y)
    }
    /// Squared length `x^2 + y^2` (unit squared), without a square root; `+inf` when it
    /// overflows (components beyond about 1.8e19), NaN when a component is NaN.
    pub fn norm2(self) -> f32 {
        self.dot(self)
    }
    /// Both components multiplied by `k` (IEEE arithmetic: no guard against NaN or overflow).
    pub fn scale(self, k: f32) -> Vec2 {
        Vec2::new(self.x * k, self.y * k)
    }
    /// The vector turned 90 degrees counter-clockwise (to the left of `self`).
    pub fn perp_left(self) -> Vec2 {
        Vec2::new(-self.y, self.x)
    }
    /// True when both components are finite (neither NaN nor infinite).
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

impl core::ops::Add for Vec2 {
    type Output = Vec2;
    fn add(self, o: Vec2) -> Vec2 {
        Vec2::new(self.x + o.x, self.y + o.y)
    }
}

impl core::ops::Sub for Vec2 {
    type Output = Vec2;
    fn sub(self, o: Vec2) -> Vec2 {
        Vec2::new(self.x - o.x, self.y - o.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm_is_hypot_without_f64() {
        let cases = [
            (3.0f32, 4.0f32),
            (1e-30, 1e-30),
            (1e-45, 0.0),
            (3e30, 4e30),
            (2e38, 1e38),
            (0.0, 0.0),
            (-7.5, 0.25),
        ];
        for (x, y) in cases {
            let h = libm::hypot(f64::from(x), f64::from(y));
            let n = f64::from(Vec2::new(x, y).norm());
            assert!((n - h).abs() <= 2.5e-7 * h, "({x}, {y}): {n} vs {h}");
        }
        assert_eq!(Vec2::new(f32::INFINITY, f32::NAN).norm(), f32::INFINITY);
        assert!(Vec2::new(f32::NAN, 1.0).norm().is_nan());
    }
}
