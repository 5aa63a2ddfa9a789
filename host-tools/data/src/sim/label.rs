//! Labelling from what happened: the outcome of a trajectory pair is read off its frames (the
//! same f32 values that are written to disk), never decided before simulating.
use crate::events::TIME_TOLERANCE_S;
use scorer_core::geometry::{box_distance, boxes_overlap};

use crate::events::{safe_rules_hold, EventKind, Frame, PrepareConfig};

/// The labelling thresholds (documented in `docs/simulator.md`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelRules {
    /// A near-crash needs a minimum box-to-box gap below this (m); default 2.0.
    pub near_crash_gap: f32,
    /// Hard braking: longitudinal deceleration of either vehicle at least this (m/s^2); default 4.0.
    pub evasive_decel: f32,
    /// Swerve: lateral acceleration of either vehicle at least this (m/s^2); default 3.0.
    pub evasive_lat_acc: f32,
    /// Safe events stay below this lateral acceleration (m/s^2; no evasive swerves, ordinary
    /// turns allowed); default 4.0.
    pub safe_max_lat_acc: f32,
    /// The evasive manoeuvre must happen within this long before the minimum gap (s); default 3.0.
    pub evasive_window: f64,
    /// The endpoint must leave this much recording before it (s), so the 4.5 s conflict
    /// sequence is complete; default 4.5.
    pub min_history: f64,
    /// Safe-sequence rules (>= 2 s, |acc| <= 1.5 m/s^2).
    pub safe: PrepareConfig,
}

impl Default for LabelRules {
    fn default() -> Self {
        Self {
            near_crash_gap: 2.0,
            evasive_decel: 4.0,
            evasive_lat_acc: 3.0,
            safe_max_lat_acc: 4.0,
            evasive_window: 3.0,
            min_history: 4.5,
            safe: PrepareConfig::default(),
        }
    }
}

/// Why a simulated interaction is not kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Rejection {
    /// The boxes touched between two 10 Hz frames but no frame shows it.
    ContactBetweenFrames,
    /// The crash or closest approach came before `min_history` seconds of recording.
    TooEarly,
    /// The gap was still shrinking at the end of the recording.
    Unresolved,
    /// Close approach or hard manoeuvre that is neither a near-crash nor safe driving.
    Incident,
}

impl Rejection {
    pub fn name(self) -> &'static str {
        match self {
            Rejection::ContactBetweenFrames => "contact_between_frames",
            Rejection::TooEarly => "too_early",
            Rejection::Unresolved => "unresolved",
            Rejection::Incident => "incident",
        }
    }
}

/// Measurements of a trajectory pair.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Measures {
    /// Index of the first frame whose boxes overlap.
    pub first_overlap: Option<usize>,
    /// Minimum box-to-box distance over the frames (m) and the index where it first occurs.
    pub min_gap: f32,
    pub min_gap_index: usize,
    /// Largest longitudinal deceleration of either vehicle (m/s^2, positive).
    pub max_decel: f32,
    /// Largest lateral acceleration of either vehicle (m/s^2).
    pub max_lat_acc: f32,
    /// Whether an evasive manoeuvre happened in the window before the minimum gap.
    pub evasive: bool,
}

/// The outcome of a trajectory pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// Crash at frame `index` (the first overlap); endpoint = its time.
    Crash {
        index: usize,
    },
    /// Near-crash with endpoint at frame `index` (first frame of the minimum gap).
    NearCrash {
        index: usize,
    },
    Safe,
    Rejected(Rejection),
}

impl Verdict {
    pub fn kind(&self) -> Option<EventKind> {
        match self {
            Verdict::Crash { .. } => Some(EventKind::Crash),
            Verdict::NearCrash { .. } => Some(EventKind::NearCrash),
            Verdict::Safe => Some(EventKind::Safe),
            Verdict::Rejected(_) => None,
        }
    }
}

/// Lateral acceleration of each vehicle at each frame: the velocity change perpendicular to the
/// heading per unit time (central differences).
fn lateral_acc(frames: &[Frame]) -> Vec<[f32; 2]> {
    let n = frames.len();
    (0..n)
        .map(|i| {
            if n < 2 {
                return [0.0; 2];
            }
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = (frames[b].time - frames[a].time) as f32;
            let lat = |fa: &scorer_core::VehicleState,
                       fb: &scorer_core::VehicleState,
                       h: &scorer_core::VehicleState| {
                let (dvx, dvy) = (fb.vx - fa.vx, fb.vy - fa.vy);
                (h.hx * dvy - h.hy * dvx).abs() / dt
            };
            let f = &frames[i];
            [
                lat(&frames[a].ego, &frames[b].ego, &f.ego),
                lat(&frames[a].partner, &frames[b].partner, &f.partner),
            ]
        })
        .collect()
}

/// Classifies a trajectory pair (with `partner.acc` already derived as the loader does).
///
/// In order: the first overlapping frame is a crash; otherwise a minimum gap below
/// `near_crash_gap` with an evasive manoeuvre (deceleration >= `evasive_decel` or lateral
/// acceleration >= `evasive_lat_acc` by either vehicle within `evasive_window` s before the
/// minimum) is a near-crash; otherwise frames meeting the safe-sequence rules with lateral acceleration below
/// `safe_max_lat_acc` are safe; anything else is rejected.
pub fn classify(frames: &[Frame], rules: &LabelRules) -> (Verdict, Measures) {
    let mut m = Measures {
        min_gap: f32::INFINITY,
        ..Measures::default()
    };
    let lat = lateral_acc(frames);
    let reach = frames.first().map_or(0.0, |f| {
        0.5 * (f.ego.length.hypot(f.ego.width) + f.partner.length.hypot(f.partner.width)) + 0.01
    });
    for (i, f) in frames.iter().enumerate() {
        m.max_decel = m.max_decel.max(-f.ego.acc).max(-f.partner.acc);
        m.max_lat_acc = m.max_lat_acc.max(lat[i][0]).max(lat[i][1]);
        // The box distance is at least the centre distance minus both half diagonals: skip the
        // exact geometry when that bound rules out contact and cannot beat the current minimum.
        let centre = (f.ego.x - f.partner.x).hypot(f.ego.y - f.partner.y);
        if m.first_overlap.is_none() && centre <= reach && boxes_overlap(&f.ego, &f.partner) {
            m.first_overlap = Some(i);
        }
        if centre - reach >= m.min_gap {
            continue;
        }
        let g = box_distance(&f.ego, &f.partner);
        if g < m.min_gap {
            m.min_gap = g;
            m.min_gap_index = i;
        }
    }
    let Some(first) = frames.first() else {
        return (Verdict::Rejected(Rejection::Incident), m);
    };
    let t0 = first.time;
    if let Some(k) = m.first_overlap {
        let v = if frames[k].time - t0 + TIME_TOLERANCE_S < rules.min_history {
            Verdict::Rejected(Rejection::TooEarly)
        } else {
            Verdict::Crash { index: k }
        };
        return (v, m);
    }
    let k = m.min_gap_index;
    let t_min = frames[k].time;
    m.evasive = frames.iter().zip(&lat).any(|(f, l)| {
        f.time <= t_min + TIME_TOLERANCE_S
            && f.time >= t_min - rules.evasive_window - TIME_TOLERANCE_S
            && (-f.ego.acc >= rules.evasive_decel
                || -f.partner.acc >= rules.evasive_decel
                || l[0] >= rules.evasive_lat_acc
                || l[1] >= rules.evasive_lat_acc)
    });
    if m.min_gap < rules.near_crash_gap && m.evasive {
        let v = if t_min - t0 + TIME_TOLERANCE_S < rules.min_history {
            Verdict::Rejected(Rejection::TooEarly)
        } else if k + 1 == frames.len() {
            Verdict::Rejected(Rejection::Unresolved)
        } else {
            Verdict::NearCrash { index: k }
        };
        return (v, m);
    }
    if safe_rules_hold(frames, &rules.safe) && m.max_lat_acc < rules.safe_max_lat_acc {
        (Verdict::Safe, m)
    } else {
        (Verdict::Rejected(Rejection::Incident), m)
    }
}
