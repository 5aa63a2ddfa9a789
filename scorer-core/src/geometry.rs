//! Oriented vehicle boxes and the exact distance between two of them.
//!
//! A vehicle is the rectangle `length x width` centred on `(x, y)` with its long axis along the
//! heading `(hx, hy)`. The heading is normalised here, so callers may pass any non-zero vector.
//!
//! All arithmetic is done relative to the first box's centre, so only the *difference* of the two
//! positions has to be accurate. Positions themselves are f32: keep them in a local frame (f32
//! resolves about 1 mm at 10 km but 0.5 m at 5,000 km, e.g. raw UTM northings); the host's
//! `riskctl ssm` re-centres each pair on the ego in f64 before converting.
//!
//! Limitations: a state with a non-finite field or a zero-length heading has no box; the functions
//! then return their documented "not computable" value ([`box_distance`]: `f32::INFINITY`,
//! [`boxes_overlap`]: `false`) instead of a NaN.
use crate::state::VehicleState;

/// A 2-D vector (m or m/s).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Vec2 {
    pub x: f32,
    pub y: f32,
}

impl Vec2 {
    pub const fn new(x: f32, y: f32) -> Self {
        Self { x, y }
    }
    pub fn dot(self, o: Vec2) -> f32 {
        self.x * o.x + self.y * o.y
    }
    /// z component of the 3-D cross product `self x o` (positive when `o` is counter-clockwise).
    pub fn cross(self, o: Vec2) -> f32 {
        self.x * o.y - self.y * o.x
    }
    pub fn norm(self) -> f32 {
        libm::hypotf(self.x, self.y)
    }
    pub fn norm2(self) -> f32 {
        self.dot(self)
    }
    pub fn scale(self, k: f32) -> Vec2 {
        Vec2::new(self.x * k, self.y * k)
    }
    /// The vector turned 90 degrees counter-clockwise (to the left of `self`).
    pub fn perp_left(self) -> Vec2 {
        Vec2::new(-self.y, self.x)
    }
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

/// Position `(x, y)` of a state.
pub fn position(s: &VehicleState) -> Vec2 {
    Vec2::new(s.x, s.y)
}

/// Velocity `(vx, vy)` of a state.
pub fn velocity(s: &VehicleState) -> Vec2 {
    Vec2::new(s.vx, s.vy)
}

/// The unit heading of a state, or `None` when `(hx, hy)` is zero or not finite.
pub fn unit_heading(s: &VehicleState) -> Option<Vec2> {
    let h = Vec2::new(s.hx, s.hy);
    let n = h.norm();
    if n > 0.0 && n.is_finite() {
        let u = h.scale(1.0 / n);
        u.is_finite().then_some(u)
    } else {
        None
    }
}

/// A vehicle footprint: centre, unit heading and half extents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientedBox {
    pub center: Vec2,
    /// Unit vector along the long axis (the heading).
    pub axis: Vec2,
    pub half_length: f32,
    pub half_width: f32,
}

impl OrientedBox {
    /// The box of a state; `None` when a field is not finite or the heading is zero.
    pub fn of(s: &VehicleState) -> Option<Self> {
        if !s.is_finite() {
            return None;
        }
        let axis = unit_heading(s)?;
        Some(Self {
            center: position(s),
            axis,
            half_length: s.length * 0.5,
            half_width: s.width * 0.5,
        })
    }

    /// The same box with its centre expressed relative to `origin`.
    pub fn relative_to(self, origin: Vec2) -> Self {
        Self {
            center: self.center - origin,
            ..self
        }
    }

    /// Corners in the reference order: front-left, front-right, rear-left, rear-right
    /// (left = counter-clockwise of the heading).
    pub fn corners(&self) -> [Vec2; 4] {
        let along = self.axis.scale(self.half_length);
        let side = self.axis.perp_left().scale(self.half_width);
        let front = self.center + along;
        let rear = self.center - along;
        [front + side, front - side, rear + side, rear - side]
    }

    /// Centre of the front edge.
    pub fn front_center(&self) -> Vec2 {
        self.center + self.axis.scale(self.half_length)
    }

    /// The four edges as (start, end) pairs, walking around the box.
    fn edges(&self) -> [(Vec2, Vec2); 4] {
        let [fl, fr, rl, rr] = self.corners();
        [(fl, fr), (fr, rr), (rr, rl), (rl, fl)]
    }

    /// Separating-axis test: true when the two boxes share at least one point (touching counts).
    fn intersects(&self, other: &OrientedBox) -> bool {
        let d = other.center - self.center;
        let axes = [
            self.axis,
            self.axis.perp_left(),
            other.axis,
            other.axis.perp_left(),
        ];
        axes.iter().all(|&n| {
            let reach = self.radius_along(n) + other.radius_along(n);
            d.dot(n).abs() <= reach
        })
    }

    /// Half the extent of the box projected on the unit direction `n`.
    fn radius_along(&self, n: Vec2) -> f32 {
        self.half_length.abs() * self.axis.dot(n).abs()
            + self.half_width.abs() * self.axis.perp_left().dot(n).abs()
    }
}

/// Distance from point `p` to the segment `[a, b]`.
fn point_segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let len2 = ab.norm2();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab.scale(t))).norm()
}

/// Exact minimum distance between the boxes of two boxes (0 when they touch or overlap).
pub fn oriented_box_distance(a: &OrientedBox, b: &OrientedBox) -> f32 {
    // Work relative to a's centre so the subtraction of large world coordinates happens once.
    let origin = a.center;
    let a = a.relative_to(origin);
    let b = b.relative_to(origin);
    if a.intersects(&b) {
        return 0.0;
    }
    // Disjoint convex polygons: the closest pair always involves a vertex of one and an edge
    // of the other.
    let mut best = f32::INFINITY;
    for (p_box, e_box) in [(&a, &b), (&b, &a)] {
        for p in p_box.corners() {
            for (s, e) in e_box.edges() {
                best = best.min(point_segment_distance(p, s, e));
            }
        }
    }
    best
}

/// Exact minimum distance (m) between the boxes of two vehicles, 0 when they touch or overlap.
///
/// Unlike the published reference implementation (which measures only from the first box's
/// corners), this is the true gap, so it never overestimates it. Returns `f32::INFINITY` when a
/// state has a non-finite field or a zero heading (no box), never NaN.
pub fn box_distance(a: &VehicleState, b: &VehicleState) -> f32 {
    match (OrientedBox::of(a), OrientedBox::of(b)) {
        (Some(ba), Some(bb)) => {
            let d = oriented_box_distance(&ba, &bb);
            if d.is_nan() {
                f32::INFINITY
            } else {
                d
            }
        }
        _ => f32::INFINITY,
    }
}

/// True when the two vehicle boxes overlap or touch (the simulator's crash test).
/// `false` when either state has no box (non-finite field or zero heading).
pub fn boxes_overlap(a: &VehicleState, b: &VehicleState) -> bool {
    match (OrientedBox::of(a), OrientedBox::of(b)) {
        (Some(ba), Some(bb)) => {
            let origin = ba.center;
            ba.relative_to(origin).intersects(&bb.relative_to(origin))
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car(x: f32, y: f32, hx: f32, hy: f32, length: f32, width: f32) -> VehicleState {
        VehicleState {
            x,
            y,
            hx,
            hy,
            length,
            width,
            ..Default::default()
        }
    }

    #[test]
    fn gap_between_aligned_boxes_is_edge_to_edge() {
        let a = car(0.0, 0.0, 1.0, 0.0, 4.0, 2.0);
        let b = car(10.0, 0.0, 1.0, 0.0, 4.0, 2.0);
        assert!((box_distance(&a, &b) - 6.0).abs() < 1e-6);
        assert!(!boxes_overlap(&a, &b));
    }

    #[test]
    fn corner_to_corner_gap() {
        let a = car(0.0, 0.0, 1.0, 0.0, 4.0, 2.0);
        let b = car(7.0, 6.0, 1.0, 0.0, 4.0, 2.0); // corners (2,1) and (5,5)
        assert!((box_distance(&a, &b) - 5.0).abs() < 1e-5);
    }

    #[test]
    fn partner_corner_against_ego_side_is_measured() {
        // A rotated partner whose corner points at the ego's side: the reference implementation
        // misses this configuration (it measures from the ego's corners only).
        let a = car(0.0, 0.0, 1.0, 0.0, 4.0, 2.0);
        let s = core::f32::consts::FRAC_1_SQRT_2;
        let corner_reach = 2.0 * s + 1.0 * s; // half-length and half-width projected on y
        let b = car(0.0, 1.0 + 0.5 + corner_reach, s, s, 4.0, 2.0);
        assert!((box_distance(&a, &b) - 0.5).abs() < 1e-5);
    }

    #[test]
    fn overlap_and_touch_are_zero() {
        let a = car(0.0, 0.0, 1.0, 0.0, 4.0, 2.0);
        let b = car(1.0, 0.5, 0.0, 1.0, 4.0, 2.0);
        assert_eq!(box_distance(&a, &b), 0.0);
        assert!(boxes_overlap(&a, &b));
        let touching = car(4.0, 0.0, 1.0, 0.0, 4.0, 2.0);
        assert_eq!(box_distance(&a, &touching), 0.0);
        assert!(boxes_overlap(&a, &touching));
    }

    #[test]
    fn heading_need_not_be_unit_and_bad_states_have_no_box() {
        let a = car(0.0, 0.0, 5.0, 0.0, 4.0, 2.0);
        let b = car(10.0, 0.0, 0.5, 0.0, 4.0, 2.0);
        assert!((box_distance(&a, &b) - 6.0).abs() < 1e-6);
        let zero = car(10.0, 0.0, 0.0, 0.0, 4.0, 2.0);
        assert_eq!(box_distance(&a, &zero), f32::INFINITY);
        let nan = car(f32::NAN, 0.0, 1.0, 0.0, 4.0, 2.0);
        assert_eq!(box_distance(&a, &nan), f32::INFINITY);
        assert!(!boxes_overlap(&a, &nan));
    }
}
