//! Scenario simulator: physically plausible two-vehicle interactions at 10 Hz, labelled from what
//! happened, written as an event folder. The model, every family and parameter distribution, and
//! the labelling thresholds are documented in `docs/simulator.md`.
//!
//! - [`world`]: paths, lateral manoeuvres, the driver model (IDM with reaction delay, distraction,
//!   gap acceptance, evasive braking/swerving) and integration.
//! - [`scenarios`]: the scenario families and their parameter distributions.
//! - [`label`]: crash / near-crash / safe / rejected, read off the written frames.
//!
//! Determinism: event `i` is drawn from its own ChaCha8 stream (`seed`, stream `i`), so the output
//! is identical for a seed whatever the thread count.
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::events::{
    derive_partner_acceleration, Event, EventKind, EventSet, EventWriter, EventsError, Frame,
    KindCounts,
};

mod family_mix;
pub mod label;
pub mod roadside_passes;
pub mod scenarios;
mod world;

pub use family_mix::{FamilyMix, FamilyMixError};
pub use label::{classify, LabelRules, Measures, Rejection, Verdict};
pub use scenarios::{Family, VehicleClass};

use scenarios::Scenario;
use world::{World, DT, FRAME_DT, SUBSTEPS};

/// File with one row of simulation metadata per event (family, vehicle classes, measures).
/// Not part of the event format; loaders ignore it.
pub const SCENARIOS_FILE: &str = "scenarios.csv";

/// The requested kind mix as relative weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mix {
    pub crash: f64,
    pub near_crash: f64,
    pub safe: f64,
}

impl Default for Mix {
    /// 70 crash : 110 near-crash : 130 safe (the 100-Car-like default of 310 events:
    /// 180 conflict and 130 safe sequences).
    fn default() -> Self {
        Self {
            crash: 70.0,
            near_crash: 110.0,
            safe: 130.0,
        }
    }
}

/// A `--mix` text that is not three weights.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixError {
    #[error("mix `{text}`: expected three numbers C,N,S ({source})")]
    NotANumber {
        text: String,
        #[source]
        source: std::num::ParseFloatError,
    },
    #[error(
        "mix `{text}`: expected three non-negative finite weights C,N,S with a positive, finite sum"
    )]
    BadWeights { text: String },
}

impl std::str::FromStr for Mix {
    type Err = MixError;

    /// `C,N,S`: three non-negative finite weights (crash, near-crash, safe) with a positive sum
    /// that is finite too (`1e308,1e308,0` overflows to infinity, and the counts would then
    /// ignore the weights: a safe event at weight 0).
    fn from_str(s: &str) -> Result<Mix, MixError> {
        let v: Vec<f64> = s
            .split(',')
            .map(|p| p.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|source| MixError::NotANumber {
                text: s.to_string(),
                source,
            })?;
        let total: f64 = v.iter().sum();
        match v[..] {
            [crash, near_crash, safe]
                if v.iter().all(|x| x.is_finite() && *x >= 0.0)
                    && total > 0.0
                    && total.is_finite() =>
            {
                Ok(Mix {
                    crash,
                    near_crash,
                    safe,
                })
            }
            _ => Err(MixError::BadWeights {
                text: s.to_string(),
            }),
        }
    }
}

impl Mix {
    /// Event counts for `n` events (largest remainder; exact for the default 310).
    pub fn counts(&self, n: usize) -> KindCounts {
        let w = [
            self.crash.max(0.0),
            self.near_crash.max(0.0),
            self.safe.max(0.0),
        ];
        let total: f64 = w.iter().sum();
        if total <= 0.0 {
            return KindCounts {
                safe: n,
                ..KindCounts::default()
            };
        }
        let exact: Vec<f64> = w.iter().map(|x| x / total * n as f64).collect();
        let mut c: Vec<usize> = exact.iter().map(|x| x.floor() as usize).collect();
        let mut order: Vec<usize> = (0..3).collect();
        order.sort_by(|&a, &b| {
            (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor()))
        });
        let mut left = n - c.iter().sum::<usize>();
        for &i in order.iter().cycle() {
            if left == 0 {
                break;
            }
            c[i] += 1;
            left -= 1;
        }
        KindCounts {
            crash: c[0],
            near_crash: c[1],
            safe: c[2],
        }
    }
}

/// Simulator settings.
#[derive(Clone, Debug)]
pub struct SimConfig {
    pub seed: u64,
    /// Number of events to produce.
    pub events: usize,
    pub mix: Mix,
    /// Scenario families drawn and their weights (`default` keeps the original data set).
    pub families: FamilyMix,
    pub rules: LabelRules,
    /// Worker threads; 0 = rayon's default (`RAYON_NUM_THREADS`, else the available parallelism).
    pub threads: usize,
    /// Show a progress bar on stderr (hidden automatically when stderr is not a terminal).
    pub progress: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            events: 310,
            mix: Mix::default(),
            families: FamilyMix::default(),
            rules: LabelRules::default(),
            threads: 0,
            progress: false,
        }
    }
}

/// Errors of a simulation run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("event {index}: no {kind} outcome in {attempts} attempts")]
    NoOutcome {
        index: usize,
        kind: EventKind,
        attempts: u64,
    },
    #[error("cannot start the simulation threads: {0}")]
    ThreadPool(#[source] rayon::ThreadPoolBuildError),
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
}

/// The most events one run simulates (at least 100 GB of event folder, about 156 GB at the default mix). A larger count is a typo or
/// a unit slip, and would hold one byte per event in memory before the first is written.
pub const MAX_EVENTS: usize = 10_000_000;

/// Bytes an event takes in the folder, at least (events.csv, frames.csv, scenarios.csv; about
/// 15.6 KB measured over 300 default-mix events, whose frame counts vary with the scenario).
pub const MIN_EVENT_BYTES: u64 = 10_000;

impl SimConfig {
    /// Refuse an event count above [`MAX_EVENTS`] or a thread count above
    /// [`crate::limits::max_threads`], and (when `out` is given) an event folder that would not
    /// fit in the free space where it is written. Checked before anything is allocated or written.
    pub fn check_size(&self, out: Option<&Path>) -> Result<(), crate::limits::LimitError> {
        use crate::limits::{check_cap, check_disk, check_memory, check_threads};
        let events = self.events as u128;
        check_cap(
            "--events",
            events,
            MAX_EVENTS as u128,
            "at least 100 GB of event folder (10 KB an event; about 156 GB at the default mix); split larger sets over seeds",
        )?;
        check_threads("--threads", self.threads)?;
        // The shuffled kind list is held whole; a wave of events is bounded and small.
        let in_memory = self.events as u64 * std::mem::size_of::<EventKind>() as u64;
        check_memory("--events", events, in_memory)?;
        if let Some(out) = out {
            check_disk(
                "--events",
                events,
                self.events as u64 * MIN_EVENT_BYTES,
                out,
            )?;
        }
        Ok(())
    }
}

/// One accepted simulated event with its provenance.
#[derive(Clone, Debug)]
pub struct SimulatedEvent {
    pub event: Event,
    pub family: Family,
    pub classes: [VehicleClass; 2],
    /// Tyre-road limit of each vehicle (ego, partner; m/s^2): its hardest braking and the radius
    /// of its friction circle (the lateral limit is this, or for a truck at most 4 m/s^2).
    pub b_phys: [f64; 2],
    pub measures: Measures,
    /// Scenarios drawn for this event (accepted one included).
    pub attempts: u64,
    /// Rejected draws by reason (including draws with a kind that was not requested).
    pub rejections: BTreeMap<&'static str, u64>,
}

/// What a run produced.
#[derive(Clone, Debug, Default)]
pub struct SimSummary {
    pub counts: KindCounts,
    pub frames: u64,
    pub attempts: u64,
    pub rejections: BTreeMap<&'static str, u64>,
    pub families: BTreeMap<&'static str, KindCounts>,
    pub elapsed: Duration,
}

impl SimSummary {
    fn add(&mut self, e: &SimulatedEvent) {
        self.counts.add(e.event.kind);
        self.frames += e.event.frames.len() as u64;
        self.attempts += e.attempts;
        for (k, v) in &e.rejections {
            *self.rejections.entry(k).or_default() += v;
        }
        self.families
            .entry(e.family.name())
            .or_default()
            .add(e.event.kind);
    }

    /// Accepted events per second of wall time.
    pub fn events_per_second(&self) -> f64 {
        self.counts.total() as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Random placement of the local scenario frame in the world: rotation and translation.
struct Placement {
    cos: f64,
    sin: f64,
    tx: f64,
    ty: f64,
}

impl Placement {
    fn draw(rng: &mut ChaCha8Rng) -> Self {
        let th = rng.random_range(0.0..std::f64::consts::TAU);
        Self {
            cos: th.cos(),
            sin: th.sin(),
            tx: rng.random_range(-500.0..500.0),
            ty: rng.random_range(-500.0..500.0),
        }
    }
    fn apply(&self, s: &mut scorer_core::VehicleState, snap: &world::Snap) {
        let r = |x: f64, y: f64| (self.cos * x - self.sin * y, self.sin * x + self.cos * y);
        let (x, y) = r(snap.x, snap.y);
        let (hx, hy) = r(snap.hx, snap.hy);
        let h = hx.hypot(hy);
        s.x = (x + self.tx) as f32;
        s.y = (y + self.ty) as f32;
        s.hx = (hx / h) as f32;
        s.hy = (hy / h) as f32;
        s.vx = (snap.speed * hx / h) as f32;
        s.vy = (snap.speed * hy / h) as f32;
    }
}

/// False when the boxes certainly do not touch (centres farther apart than the half diagonals).
fn may_touch(world: &World, a: &world::Snap, b: &world::Snap) -> bool {
    let r = |ag: &world::Agent| 0.5 * (ag.length * ag.length + ag.width * ag.width).sqrt();
    let reach = r(&world.agents[0]) + r(&world.agents[1]) + 0.01;
    let (dx, dy) = (a.x - b.x, a.y - b.y);
    dx * dx + dy * dy <= reach * reach
}

/// Runs a scenario to its horizon or first overlapping frame. Returns the frames (with the
/// partner acceleration derived as the loader does) and whether the boxes touched between
/// frames without any frame showing it.
fn run(scn: Scenario, place: &Placement) -> (Vec<Frame>, bool) {
    let n_frames = (scn.horizon / FRAME_DT).round() as usize + 1;
    let mut world = World::new(scn.agents);
    let mut frames = Vec::with_capacity(n_frames);
    let mut prev_speed = world.snaps()[0].speed;
    let mut acc_ego = world.agents[0].a;
    let mut touched = false;
    for k in 0..n_frames {
        if k > 0 {
            for _ in 0..SUBSTEPS {
                world.step();
                let [s0, s1] = world.snaps();
                acc_ego = (s0.speed - prev_speed) / DT;
                prev_speed = s0.speed;
                if may_touch(&world, &s0, &s1) {
                    let (a, b) = (
                        world.agents[0].state(&s0, 0.0),
                        world.agents[1].state(&s1, 0.0),
                    );
                    touched |= scorer_core::geometry::boxes_overlap(&a, &b);
                }
            }
        }
        let [s0, s1] = world.snaps();
        let mut ego = world.agents[0].state(&s0, acc_ego);
        let mut partner = world.agents[1].state(&s1, 0.0);
        place.apply(&mut ego, &s0);
        place.apply(&mut partner, &s1);
        frames.push(Frame {
            time: k as f64 / 10.0,
            ego,
            partner,
        });
        if scorer_core::geometry::boxes_overlap(&ego, &partner) {
            touched = false;
            break;
        }
        if touched {
            break;
        }
    }
    derive_partner_acceleration(&mut frames);
    (frames, touched)
}

/// Simulates event number `index` of a run with `seed`, drawing scenarios of the `families` mix
/// until one ends as `kind` (hazardous parameter regime for crash/near-crash, benign for safe).
pub fn simulate_one(
    seed: u64,
    index: usize,
    kind: EventKind,
    rules: &LabelRules,
    families: &FamilyMix,
) -> Result<SimulatedEvent, SimError> {
    const MAX_ATTEMPTS: u64 = 20_000;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index as u64);
    let mut rejections: BTreeMap<&'static str, u64> = BTreeMap::new();
    for attempt in 1..=MAX_ATTEMPTS {
        let family = families.draw(&mut rng);
        let scn = scenarios::build(family, &mut rng, kind.is_conflict());
        let (family, classes) = (scn.family, scn.classes);
        let b_phys = [scn.agents[0].b_phys, scn.agents[1].b_phys];
        let place = Placement::draw(&mut rng);
        let (mut frames, touched) = run(scn, &place);
        if touched {
            *rejections
                .entry(Rejection::ContactBetweenFrames.name())
                .or_default() += 1;
            continue;
        }
        let (verdict, measures) = classify(&frames, rules);
        let (t_impact, keep) = match verdict {
            Verdict::Rejected(r) => {
                *rejections.entry(r.name()).or_default() += 1;
                continue;
            }
            v if v.kind() != Some(kind) => {
                *rejections.entry(other_kind(v)).or_default() += 1;
                continue;
            }
            Verdict::Crash { index } => (Some(frames[index].time), index + 1),
            Verdict::NearCrash { index } => {
                let extra = (rng.random_range(0.5..2.0) / FRAME_DT).round() as usize;
                (
                    Some(frames[index].time),
                    (index + 1 + extra).min(frames.len()),
                )
            }
            Verdict::Safe => (None, frames.len()),
        };
        if keep < frames.len() {
            frames.truncate(keep);
            derive_partner_acceleration(&mut frames);
            // The end frames' partner acceleration changed: the label must still hold.
            if classify(&frames, rules).0.kind() != Some(kind) {
                *rejections.entry("label_changed_by_cut").or_default() += 1;
                continue;
            }
        }
        let (t_start, t_end) = (frames[0].time, frames[frames.len() - 1].time);
        let e = &frames[0];
        let event = Event {
            id: String::new(),
            kind,
            t_start,
            t_end,
            t_impact,
            dims: crate::events::Dims {
                length_ego: e.ego.length,
                width_ego: e.ego.width,
                length_partner: e.partner.length,
                width_partner: e.partner.width,
            },
            frames,
        };
        return Ok(SimulatedEvent {
            event,
            family,
            classes,
            b_phys,
            measures,
            attempts: attempt,
            rejections,
        });
    }
    Err(SimError::NoOutcome {
        index,
        kind,
        attempts: MAX_ATTEMPTS,
    })
}

fn other_kind(v: Verdict) -> &'static str {
    match v.kind() {
        Some(EventKind::Crash) => "surplus_crash",
        Some(EventKind::NearCrash) => "surplus_near_crash",
        Some(EventKind::Safe) => "surplus_safe",
        None => "rejected",
    }
}

/// The requested kind of every event index: the mix counts in a seeded random order.
fn targets(cfg: &SimConfig) -> Vec<EventKind> {
    let c = cfg.mix.counts(cfg.events);
    let mut v: Vec<EventKind> = EventKind::ALL
        .iter()
        .flat_map(|&k| std::iter::repeat_n(k, c.get(k)))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    rng.set_stream(u64::MAX);
    v.shuffle(&mut rng);
    v
}

fn id_width(n: usize) -> usize {
    n.to_string().len().max(6)
}

/// Simulates the configured events and hands each to `sink` in index order, computing waves of
/// events on a rayon pool of `cfg.threads` threads. Memory stays bounded by one wave.
fn generate(
    cfg: &SimConfig,
    mut sink: impl FnMut(SimulatedEvent) -> Result<(), SimError>,
) -> Result<SimSummary, SimError> {
    const CHUNK: usize = 16;
    cfg.check_size(None)?;
    let start = Instant::now();
    let kinds = targets(cfg);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads)
        .build()
        .map_err(SimError::ThreadPool)?;
    let bar = if cfg.progress {
        let b = indicatif::ProgressBar::with_draw_target(
            Some(kinds.len() as u64),
            indicatif::ProgressDrawTarget::stderr(),
        );
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "simulate {bar:40} {pos}/{len} events  {per_sec}  eta {eta}",
        ) {
            b.set_style(style);
        }
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let width = id_width(kinds.len());
    let mut summary = SimSummary::default();
    let wave = CHUNK * pool.current_num_threads() * 4;
    for wave_start in (0..kinds.len()).step_by(wave.max(1)) {
        let wave_end = (wave_start + wave).min(kinds.len());
        // Each event draws from its own seed (`simulate_one(seed, index, ..)`), and `collect` keeps
        // index order, so the output is the same whatever the thread count or scheduling.
        let results: Vec<(usize, Result<SimulatedEvent, SimError>)> = pool.install(|| {
            (wave_start..wave_end)
                .into_par_iter()
                .with_min_len(CHUNK)
                .map(|i| {
                    let r = simulate_one(cfg.seed, i, kinds[i], &cfg.rules, &cfg.families);
                    bar.inc(1);
                    (i, r)
                })
                .collect()
        });
        for (i, r) in results {
            let mut e = r?;
            e.event.id = format!("{:0width$}", i + 1);
            summary.add(&e);
            sink(e)?;
        }
    }
    bar.finish_and_clear();
    summary.elapsed = start.elapsed();
    Ok(summary)
}

/// Simulates `cfg.events` events and streams them into the event folder `dir` (plus
/// [`SCENARIOS_FILE`] with per-event metadata).
pub fn simulate_to_dir(dir: &Path, cfg: &SimConfig) -> Result<SimSummary, SimError> {
    let mut writer = EventWriter::create(dir)?;
    let meta_path = dir.join(SCENARIOS_FILE);
    let meta_io = |e| SimError::Io {
        path: meta_path.clone(),
        source: e,
    };
    // Through the output layer, like the event files: renamed into place with them, never
    // truncated in place.
    let mut meta = riskscore_output::AtomicFile::create(&meta_path).map_err(meta_io)?;
    writeln!(
        meta,
        "event_id,kind,family,ego_class,sur_class,min_gap,max_decel,max_lat_acc,attempts"
    )
    .map_err(meta_io)?;
    let summary = generate(cfg, |e| {
        writer.write_event(&e.event)?;
        let m = &e.measures;
        writeln!(
            meta,
            "{},{},{},{},{},{},{},{},{}",
            e.event.id,
            e.event.kind,
            e.family.name(),
            e.classes[0].name(),
            e.classes[1].name(),
            m.min_gap,
            m.max_decel,
            m.max_lat_acc,
            e.attempts
        )
        .map_err(meta_io)
    })?;
    writer.finish_with(vec![meta])?;
    Ok(summary)
}

/// Simulates `cfg.events` events in memory (for small sets, tests and the demo).
pub fn simulate_events(
    cfg: &SimConfig,
) -> Result<(EventSet, Vec<SimulatedEvent>, SimSummary), SimError> {
    let mut all = Vec::with_capacity(cfg.events);
    let summary = generate(cfg, |e| {
        all.push(e);
        Ok(())
    })?;
    let set = EventSet {
        events: all.iter().map(|e| e.event.clone()).collect(),
    };
    Ok((set, all, summary))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::{LENGTH_RANGE_M, WIDTH_RANGE_M};

    /// Outcome counts per family and regime over `n` draws: [crash, near_crash, safe, rejected].
    fn outcomes(family: Family, hazardous: bool, n: u64) -> [u32; 4] {
        let rules = LabelRules::default();
        let mut c = [0u32; 4];
        for i in 0..n {
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            rng.set_stream(i);
            let scn = scenarios::build(family, &mut rng, hazardous);
            let place = Placement::draw(&mut rng);
            let (frames, touched) = run(scn, &place);
            let k = if touched {
                3
            } else {
                match classify(&frames, &rules).0 {
                    Verdict::Crash { .. } => 0,
                    Verdict::NearCrash { .. } => 1,
                    Verdict::Safe => 2,
                    Verdict::Rejected(_) => 3,
                }
            };
            c[k] += 1;
        }
        c
    }

    #[test]
    fn every_family_produces_conflicts_and_safe_events() {
        for f in Family::ALL {
            let hz = outcomes(f, true, 150);
            let bn = outcomes(f, false, 150);
            eprintln!("{:<17} hazardous {:?} benign {:?}", f.name(), hz, bn);
            assert!(hz[0] > 0, "{}: no crash from hazardous draws", f.name());
            assert!(
                hz[1] > 0,
                "{}: no near-crash from hazardous draws",
                f.name()
            );
            assert!(bn[2] > 0, "{}: no safe event from benign draws", f.name());
        }
    }

    #[test]
    fn every_family_draws_boxes_the_event_loader_accepts() {
        let (lengths, widths) = (LENGTH_RANGE_M, WIDTH_RANGE_M);
        for f in Family::ALL {
            for (i, hazardous) in (0..2000u64).flat_map(|i| [(i, true), (i, false)]) {
                let mut rng = ChaCha8Rng::seed_from_u64(11);
                rng.set_stream(i);
                for a in scenarios::build(f, &mut rng, hazardous).agents {
                    let (l, w) = (a.length as f32, a.width as f32);
                    assert!(
                        (lengths.0..=lengths.1).contains(&l) && (widths.0..=widths.1).contains(&w),
                        "{} draw {i}: a {l} x {w} m box is outside the loader's range",
                        f.name()
                    );
                }
            }
        }
    }

    #[test]
    fn mix_parses_three_weights_and_names_what_is_wrong() {
        let m: Mix = " 1, 2 ,3".parse().unwrap();
        assert_eq!((m.crash, m.near_crash, m.safe), (1.0, 2.0, 3.0));
        let e = "1,x,3".parse::<Mix>().unwrap_err();
        assert!(matches!(e, MixError::NotANumber { .. }));
        assert!(
            std::error::Error::source(&e).is_some(),
            "the float error is kept"
        );
        for bad in [
            "1,2",
            "1,2,3,4",
            "0,0,0",
            "1,-1,1",
            "1,inf,1",
            "1e308,1e308,0",
        ] {
            assert_eq!(
                bad.parse::<Mix>(),
                Err(MixError::BadWeights { text: bad.into() }),
                "{bad}"
            );
        }
    }
}
