//! Reference paths (lines and circular arcs) and the smooth lateral offsets vehicles drive on them.
/// One piece of a reference path.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Seg {
    Line(f64),
    /// Circular arc of length `len` and signed curvature `kappa` (positive turns left).
    Arc {
        len: f64,
        kappa: f64,
    },
}

/// A reference path: a start pose and segments; extended straight before and after.
#[derive(Clone, Debug)]
pub(crate) struct Path {
    /// (s at segment start, x, y, psi) for each segment, plus the end pose.
    knots: Vec<(f64, f64, f64, f64)>,
    segs: Vec<Seg>,
}

/// Position, heading angle and curvature of a path point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pose {
    pub x: f64,
    pub y: f64,
    pub psi: f64,
    pub kappa: f64,
}

impl Path {
    pub fn new(x: f64, y: f64, psi: f64, segs: Vec<Seg>) -> Self {
        let mut knots = vec![(0.0, x, y, psi)];
        for seg in &segs {
            let &(s0, x0, y0, p0) = knots.last().unwrap_or(&(0.0, x, y, psi));
            let (len, end) = match *seg {
                Seg::Line(len) => (len, line_pose(x0, y0, p0, len)),
                Seg::Arc { len, kappa } => (len, arc_pose(x0, y0, p0, kappa, len)),
            };
            knots.push((s0 + len, end.x, end.y, end.psi));
        }
        Self { knots, segs }
    }

    /// An endless straight line through `(x, y)` with heading `psi`.
    pub fn line(x: f64, y: f64, psi: f64) -> Self {
        Self::new(x, y, psi, Vec::new())
    }

    pub fn pose(&self, s: f64) -> Pose {
        let &(_, x0, y0, p0) = &self.knots[0];
        if s <= 0.0 {
            return line_pose(x0, y0, p0, s);
        }
        if let Some((i, kappa)) = self.segment_at(s) {
            let (k0, kx, ky, kp) = self.knots[i];
            return if kappa == 0.0 {
                line_pose(kx, ky, kp, s - k0)
            } else {
                arc_pose(kx, ky, kp, kappa, s - k0)
            };
        }
        let &(k0, kx, ky, kp) = self.knots.last().unwrap_or(&self.knots[0]);
        line_pose(kx, ky, kp, s - k0)
    }

    /// The curvature of the path at `s` (what `pose(s).kappa` gives, without the trigonometry).
    pub fn kappa(&self, s: f64) -> f64 {
        if s <= 0.0 {
            return 0.0;
        }
        self.segment_at(s).map_or(0.0, |(_, kappa)| kappa)
    }

    /// The segment `s` (> 0) lies on and its curvature; `None` beyond the last one.
    fn segment_at(&self, s: f64) -> Option<(usize, f64)> {
        self.segs.iter().enumerate().find_map(|(i, seg)| {
            let (len, kappa) = match *seg {
                Seg::Line(len) => (len, 0.0),
                Seg::Arc { len, kappa } => (len, kappa),
            };
            (s < self.knots[i].0 + len).then_some((i, kappa))
        })
    }

    /// Distance from `s` to the next arc (0 inside one) and its radius, looking `range` m ahead.
    pub fn arc_ahead(&self, s: f64, range: f64) -> Option<(f64, f64)> {
        for (i, seg) in self.segs.iter().enumerate() {
            if let Seg::Arc { len, kappa } = *seg {
                let k0 = self.knots[i].0;
                if s < k0 + len && k0 - s <= range {
                    return Some(((k0 - s).max(0.0), 1.0 / kappa.abs()));
                }
            }
        }
        None
    }
}

fn line_pose(x: f64, y: f64, psi: f64, u: f64) -> Pose {
    Pose {
        x: x + u * psi.cos(),
        y: y + u * psi.sin(),
        psi,
        kappa: 0.0,
    }
}

fn arc_pose(x: f64, y: f64, psi: f64, kappa: f64, u: f64) -> Pose {
    let p1 = psi + kappa * u;
    Pose {
        x: x + (p1.sin() - psi.sin()) / kappa,
        y: y - (p1.cos() - psi.cos()) / kappa,
        psi: p1,
        kappa,
    }
}

/// A smooth lateral move from offset `d0` to `d1` over path distance `[s0, s0 + len]`
/// (quintic with zero slope and curvature at both ends).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LatMove {
    pub s0: f64,
    pub len: f64,
    pub d0: f64,
    pub d1: f64,
}

impl LatMove {
    /// Offset and its slope d'(s).
    pub fn eval(&self, s: f64) -> (f64, f64) {
        let u = ((s - self.s0) / self.len).clamp(0.0, 1.0);
        let q = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
        let dq = 30.0 * u * u * (1.0 - u) * (1.0 - u);
        let dd = self.d1 - self.d0;
        (self.d0 + dd * q, dd * dq / self.len)
    }
    /// The offset's second derivative d''(s) (1/m): the curvature the move adds to the path.
    pub fn curvature(&self, s: f64) -> f64 {
        let u = (s - self.s0) / self.len;
        if !(0.0..=1.0).contains(&u) {
            return 0.0;
        }
        let ddq = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u);
        (self.d1 - self.d0) * ddq / (self.len * self.len)
    }
}

/// The lateral offset of a vehicle: a sum of smooth moves, so a move started during another
/// (a swerve during a lane change, an abort) keeps offset, heading and curvature continuous.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lateral {
    moves: Vec<LatMove>,
}

impl Lateral {
    /// Offset and its slope d'(s).
    pub fn eval(&self, s: f64) -> (f64, f64) {
        self.moves.iter().fold((0.0, 0.0), |(d, d1), m| {
            let (a, b) = m.eval(s);
            (d + a, d1 + b)
        })
    }
    /// The curvature (1/m) all moves under way add to the reference path at `s`.
    pub fn curvature(&self, s: f64) -> f64 {
        self.moves.iter().map(|m| m.curvature(s)).sum()
    }
    /// The offset once every move has finished.
    pub fn target(&self) -> f64 {
        self.moves.iter().map(|m| m.d1).sum()
    }
    /// Adds a move of `dd` m over `[s, s + len]`.
    pub fn start(&mut self, s: f64, dd: f64, len: f64) {
        self.moves.push(LatMove {
            s0: s,
            len,
            d0: 0.0,
            d1: dd,
        });
    }
}

/// Peak of |d''(s)| of a quintic move, per metre moved and per 1/len^2: the profile's second
/// derivative is 60 u (1 - u) (1 - 2 u) dd / len^2, largest at u = 1/2 -+ sqrt(3)/6, where it is
/// exactly 10 / sqrt(3) = 5.7735... (`f64::sqrt` is not `const`: the literal is that quotient
/// rounded to f64, checked bit for bit in the tests). It was 5.77 before 2026-11-29, which let
/// a sized move peak 0.06 % over its limit.
const QUINTIC_PEAK: f64 = 5.773_502_691_896_258;

/// What a vehicle can do sideways: the lateral acceleration its tyres (or, for a truck, its
/// rollover threshold) allow, and the tightest radius it can steer.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Handling {
    /// m/s^2.
    pub lat_max: f64,
    /// m.
    pub r_min: f64,
}

/// Path distance needed for a lateral move of `dd` m at speed `v` whose peak lateral
/// acceleration is `alat` or the vehicle's limit, whichever is lower, and whose peak curvature
/// stays within the vehicle's turning circle (quintic profile: peak d'' = `QUINTIC_PEAK` dd / len^2).
pub(crate) fn lateral_len(v: f64, dd: f64, alat: f64, handling: &Handling) -> f64 {
    let dd = dd.abs();
    let alat = alat.min(handling.lat_max);
    (v * (QUINTIC_PEAK * dd / alat).sqrt())
        .max((QUINTIC_PEAK * dd * handling.r_min).sqrt())
        .max(3.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arcs_join_lines_continuously() {
        // Quarter left turn of radius 10 after 5 m, then straight.
        let p = Path::new(
            1.0,
            2.0,
            0.0,
            vec![
                Seg::Line(5.0),
                Seg::Arc {
                    len: 10.0 * std::f64::consts::FRAC_PI_2,
                    kappa: 0.1,
                },
                Seg::Line(20.0),
            ],
        );
        let end = p.pose(5.0 + 10.0 * std::f64::consts::FRAC_PI_2);
        assert!(
            (end.x - 16.0).abs() < 1e-9 && (end.y - 12.0).abs() < 1e-9,
            "{end:?}"
        );
        assert!((end.psi - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Unit speed along the path everywhere, including across joints and the extensions.
        let mut s = -3.0;
        while s < 45.0 {
            let (a, b) = (p.pose(s), p.pose(s + 1e-4));
            let step = (b.x - a.x).hypot(b.y - a.y) / 1e-4;
            assert!((step - 1.0).abs() < 1e-3, "s = {s}: {step}");
            s += 0.37;
        }
        assert_eq!(
            p.arc_ahead(0.0, 10.0).map(|(d, r)| (d, r.round())),
            Some((5.0, 10.0))
        );
        assert!(p.arc_ahead(0.0, 4.0).is_none());
        assert!(p.arc_ahead(30.0, 100.0).is_none());
    }

    #[test]
    fn lateral_moves_are_smooth_and_superpose() {
        let mut lat = Lateral::default();
        lat.start(10.0, 3.5, 50.0);
        assert_eq!(lat.eval(10.0), (0.0, 0.0));
        let (d, d1) = lat.eval(35.0);
        assert!((d - 1.75).abs() < 1e-12 && (d1 - 3.5 * 1.875 / 50.0).abs() < 1e-12);
        assert_eq!(lat.eval(60.0), (3.5, 0.0));
        // A second move started mid-way keeps the slope continuous.
        let before = lat.eval(30.0);
        lat.start(30.0, -3.5, 20.0);
        assert_eq!(lat.eval(30.0), before);
        assert!((lat.target()).abs() < 1e-12);
        assert!(lat.eval(100.0).0.abs() < 1e-12);
        // Peak lateral acceleration of a move matches `lateral_len`, and `curvature` is d''(s).
        let roomy = Handling {
            lat_max: 9.0,
            r_min: 5.0,
        };
        let len = lateral_len(20.0, 2.0, 4.0, &roomy);
        let m = LatMove {
            s0: 0.0,
            len,
            d0: 0.0,
            d1: 2.0,
        };
        let h = 1e-3;
        let peak = (1..1000)
            .map(|i| {
                let s = len * i as f64 / 1000.0;
                let second = (m.eval(s + h).1 - m.eval(s - h).1) / (2.0 * h);
                assert!((second - m.curvature(s)).abs() < 1e-6, "s = {s}");
                (second * 400.0).abs()
            })
            .fold(0.0, f64::max);
        assert!((peak - 4.0).abs() < 0.02, "{peak}");
        assert_eq!(m.curvature(-1.0), 0.0);
        assert_eq!(m.curvature(len + 1.0), 0.0);
    }

    #[test]
    fn lateral_moves_stay_within_the_vehicles_handling() {
        // A truck asked for 7 m/s^2 gets its rollover limit: the move is longer.
        let truck = Handling {
            lat_max: 4.0,
            r_min: 8.0,
        };
        let len = lateral_len(20.0, 2.0, 7.0, &truck);
        assert!(
            (QUINTIC_PEAK * 2.0 * 400.0 / (len * len) - 4.0).abs() < 1e-9,
            "{len}"
        );
        // At walking speed the turning circle, not the lateral acceleration, sets the length:
        // peak curvature QUINTIC_PEAK dd / len^2 = 1 / r_min.
        let car = Handling {
            lat_max: 9.0,
            r_min: 5.0,
        };
        let len = lateral_len(1.0, 2.2, 7.0, &car);
        assert!(
            (QUINTIC_PEAK * 2.2 / (len * len) - 1.0 / 5.0).abs() < 1e-12,
            "{len}"
        );
        assert!(len > 7.9, "{len}");
    }

    #[test]
    fn quintic_peak_is_the_profiles_exact_peak() {
        assert_eq!(QUINTIC_PEAK.to_bits(), (10.0 / 3f64.sqrt()).to_bits());
        // Analytic: d'' = 60 u (1 - u) (1 - 2 u) dd / len^2 at u = 1/2 - sqrt(3)/6.
        let u = 0.5 - 3f64.sqrt() / 6.0;
        let analytic = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u);
        assert!((analytic - QUINTIC_PEAK).abs() < 1e-12, "{analytic}");
        // Numerical: the largest |d''| of a move, by central differences of its slope on a fine
        // grid, scaled by len^2 / dd, matches it (and the old 5.77 does not).
        let (len, dd) = (37.0, 2.6);
        let m = LatMove {
            s0: 5.0,
            len,
            d0: 0.4,
            d1: 0.4 + dd,
        };
        let h = 1e-4;
        let peak = (1..100_000)
            .map(|i| {
                let s = 5.0 + len * f64::from(i) / 100_000.0;
                ((m.eval(s + h).1 - m.eval(s - h).1) / (2.0 * h)).abs()
            })
            .fold(0.0, f64::max)
            * len
            * len
            / dd;
        assert!((peak - QUINTIC_PEAK).abs() < 1e-6, "{peak}");
        assert!(peak - 5.77 > 3e-3, "{peak}");
        // A move sized for a limit peaks at that limit, not above it.
        let car = Handling {
            lat_max: 9.0,
            r_min: 5.0,
        };
        let len = lateral_len(15.0, 3.0, 4.0, &car);
        let m = LatMove {
            s0: 0.0,
            len,
            d0: 0.0,
            d1: 3.0,
        };
        let peak = (0..=100_000)
            .map(|i| (m.curvature(len * f64::from(i) / 100_000.0) * 225.0).abs())
            .fold(0.0, f64::max);
        assert!(peak <= 4.0 + 1e-12 && peak > 4.0 - 1e-6, "{peak}");
    }
}
