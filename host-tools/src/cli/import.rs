//! `riskctl import`: recorded data in other formats to event folders.
use std::path::PathBuf;

use anyhow::{bail, Context};
use riskscore_data::events::PrepareConfig;
use riskscore_data::import::commonroad::{
    geometry_index, import_to_dir, EgoChoice, GeometrySet, ImportSummary, InteractionRules,
    FAR_COORDINATE_M,
};
use scorer_core::interaction::Geometry;

/// Import recorded data as an event folder.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Recorded CommonRoad scenarios (XML) to an event folder of real safe interactions.
    Commonroad(CommonRoadArgs),
}

const ABOUT_COMMONROAD: &str = "\
Rules (docs/real-data.md):
  Road users: <dynamicObstacle> (2020a) or 2018b <obstacle> with <role>dynamic</role>, of a vehicle
  type (car, truck, bus, taxi, priorityVehicle, motorcycle, bicycle) with one <rectangle> shape and
  a recorded <trajectory>. Static, environment and phantom obstacles, other types, other shapes,
  planning problems and the road network are ignored (counted in the summary).
  Conversion: time = step x timeStepSize; box centre = position; heading = (cos, sin) of
  orientation; (vx, vy) = velocity x heading; acc_ego / acc_sur = recorded acceleration (derived
  from the velocity when absent); box size from the rectangle.
  Geometry (scorer_core::interaction, shared with every tool): headings within 30 deg travel the
  same way (following: centre within 1.8 m of the ego's centre line; else adjacent), beyond
  150 deg oncoming, in between crossing.
  Near: both recorded at a step, boxes not overlapping (an overlap is a recording artefact: that
  step is dropped and the interaction split there), box gap <= --max-gap, and
    same way (following, adjacent): lateral centre offset across either heading <= --max-lateral;
    crossing, oncoming: moving on at constant velocities, the centres come within
    --max-approach m of each other in the next --horizon s (now included).
  An interaction is a run of consecutive near steps; its ego is chosen by --ego. Each
  interaction is cut by the safe-sequence rules (both |acc| <= --max-acc, pieces of
  --min-duration to --max-duration s) into `safe` events with id
  {scenario}/{ego}-{partner}@{first step}#{piece}; the scenario id (file stem) comes first, so
  data can be split by scenario file. Each event is filed under its geometry at closest approach
  (smallest box gap, seen from its ego); --geometry keeps only the listed ones. The folder's
  scenarios.csv lists every event's scenario, geometry, closest-approach time, gap and speeds.
  Overlapping files: --skip-repeats drops the pair-steps an earlier file already holds (the same
  two obstacle ids at the same moment, even when the files' clocks and origins differ), so one
  recorded interaction is not imported twice under two scenario ids (NGSIM US-101 10_1/10_4,
  23_1/24_1, Peachtree 4_1/4_2 overlap in time).
  Noisy recordings: --smooth-speed S derives the acceleration (for the |acc| rule and the
  acc columns) from the speed averaged over a centred S-second window instead of the recorded
  value (video-tracked data such as NGSIM Lankershim/Peachtree; docs/real-data.md has the yield).
Values: every state needs <position><point>, <orientation>, <time> and <velocity> as <exact>
values (an <intervalStart>/<intervalEnd> value is refused: it is no recording); <acceleration>
is optional. A file whose coordinates reach beyond 100 km (UTM, say) is taken relative to a
local origin, and the summary names it. Compressed files (.xml.gz, ...) are named and skipped.
Errors name the file, line, obstacle and element (e.g. `x.xml:812: <dynamicObstacle id=42>
<state> #3: missing <velocity>`); the malformed road user or file is skipped, the rest written.
The command fails, leaving --out as it was, only when no file could be read or no safe sequence
was found.
Next: the folder is real normal driving (safe events only). Train with it as such:
`riskctl demo --real DIR` or `--extra-real DIR` (docs/training.md, \"Real normal driving\"), and
hold real data out by scenario file, never by event (the two ego orders of one interaction are
near-duplicates).

Example (SCENARIOS is a folder of CommonRoad XML files, e.g. the NGSIM US-101 benchmark
scenarios USA_US101-*.xml from the CommonRoad scenario collection; data/ngsim-us101-safe/
PROVENANCE.md lists the files and their checksum):
  riskctl import commonroad --out my-safe-events SCENARIOS/
City traffic with crossing and oncoming partners only, acceleration from a 1 s smoothed speed
(data/ngsim-urban-safe/PROVENANCE.md has the command of the shipped urban extract):
  riskctl import commonroad --out city --geometry crossing,oncoming --smooth-speed 1 \\
      --skip-repeats ngsim-urban/";

/// Recorded CommonRoad scenarios (XML) to an event folder of real safe interactions.
#[derive(clap::Args, Debug)]
#[command(after_long_help = ABOUT_COMMONROAD)]
pub struct CommonRoadArgs {
    /// Output event folder (created; existing event files are replaced).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Scenario files and folders (searched recursively for *.xml). Compressed files
    /// (*.xml.gz, ...) are named and skipped: decompress them first.
    #[arg(value_name = "FILE_OR_DIR", required = true)]
    pub inputs: Vec<PathBuf>,
    /// Largest gap between the two boxes for a step to count as near (m).
    #[arg(long, allow_negative_numbers = true, default_value_t = 30.0)]
    pub max_gap: f32,
    /// Road users travelling the same way: largest lateral centre offset across either one's
    /// heading (m); 5 = same or adjacent lane on 3.7 m lanes.
    #[arg(long, allow_negative_numbers = true, default_value_t = InteractionRules::default().max_lateral)]
    pub max_lateral: f32,
    /// Crossing and oncoming road users: largest centre distance of their predicted closest
    /// approach within --horizon (m).
    #[arg(long, allow_negative_numbers = true, default_value_t = InteractionRules::default().max_approach)]
    pub max_approach: f32,
    /// Crossing and oncoming road users: how far ahead the closest approach is predicted (s).
    #[arg(long, allow_negative_numbers = true, default_value_t = InteractionRules::default().horizon)]
    pub horizon: f32,
    /// Geometries to keep, by each event's geometry at closest approach: comma-separated
    /// `following,adjacent,crossing,oncoming`, or `all`.
    #[arg(long, default_value = "all", value_parser = GeometrySet::parse)]
    pub geometry: GeometrySet,
    /// Derive the acceleration from the speed averaged over a centred window of this many
    /// seconds instead of the recorded value (0: recorded). For noisy video-tracked data.
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 0.0,
        value_name = "SECONDS"
    )]
    pub smooth_speed: f64,
    /// Drop the pair-steps an earlier input file already holds: the same two vehicles (obstacle
    /// ids) at the same moment, as in benchmark files cut from one recording with overlapping
    /// time windows (tracks lined up by speed and position, within 5 cm, on one step offset and
    /// translation per earlier file). Files are taken in name order; the first keeps the moment.
    #[arg(long)]
    pub skip_repeats: bool,
    /// Ego of an interaction: `both` (both orders, two mirror-image events: the scorer rates
    /// every surrounding road user, ahead or behind) or `follower` (only the road user with the
    /// partner ahead on average; half the data).
    #[arg(long, default_value = "both", value_parser = ["both", "follower"])]
    pub ego: String,
    /// Shortest safe sequence (s).
    #[arg(long, allow_negative_numbers = true, default_value_t = PrepareConfig::default().safe_min_duration)]
    pub min_duration: f64,
    /// Longest safe sequence (s); longer calm stretches are split.
    #[arg(long, allow_negative_numbers = true, default_value_t = PrepareConfig::default().safe_max_duration)]
    pub max_duration: f64,
    /// Largest |longitudinal acceleration| of either road user in a safe sequence (m/s^2).
    #[arg(long, allow_negative_numbers = true, default_value_t = PrepareConfig::default().safe_max_abs_acc)]
    pub max_acc: f32,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Commonroad(a) => commonroad(a),
    }
}

fn commonroad(a: CommonRoadArgs) -> anyhow::Result<()> {
    let positive = |name: &str, v: f64| -> anyhow::Result<()> {
        if !(v.is_finite() && v > 0.0) {
            bail!("--{name} must be a positive number, got {v}");
        }
        Ok(())
    };
    positive("max-gap", f64::from(a.max_gap))?;
    positive("max-lateral", f64::from(a.max_lateral))?;
    positive("max-approach", f64::from(a.max_approach))?;
    positive("horizon", f64::from(a.horizon))?;
    if !(a.smooth_speed.is_finite() && a.smooth_speed >= 0.0) {
        bail!(
            "--smooth-speed must be 0 (off) or a positive number of seconds, got {}",
            a.smooth_speed
        );
    }
    positive("min-duration", a.min_duration)?;
    positive("max-duration", a.max_duration)?;
    positive("max-acc", f64::from(a.max_acc))?;
    if a.max_duration < a.min_duration {
        bail!(
            "--max-duration {} is below --min-duration {}",
            a.max_duration,
            a.min_duration
        );
    }
    let rules = InteractionRules {
        max_gap: a.max_gap,
        max_lateral: a.max_lateral,
        max_approach: a.max_approach,
        horizon: a.horizon,
        geometries: a.geometry,
        speed_smoothing: a.smooth_speed,
        skip_repeats: a.skip_repeats,
        ego: if a.ego == "both" {
            EgoChoice::Both
        } else {
            EgoChoice::Follower
        },
        safe: PrepareConfig {
            safe_min_duration: a.min_duration,
            safe_max_duration: a.max_duration,
            safe_max_abs_acc: a.max_acc,
            ..PrepareConfig::default()
        },
    };
    let inputs: Vec<(&str, &std::path::Path)> =
        a.inputs.iter().map(|p| ("INPUT", p.as_path())).collect();
    super::output::refuse(&inputs, &[("--out", &a.out)])?;
    let s = import_to_dir(&a.inputs, &a.out, &rules)
        .with_context(|| format!("importing into {}", a.out.display()))?;
    for issue in &s.issues {
        eprintln!("riskctl: skipped: {issue}");
    }
    let untouched = super::output::left_alone(&a.out);
    if s.files == 0 && s.issues.is_empty() {
        // Nothing was even tried: the inputs hold no scenario file (an event folder, say).
        let inputs: Vec<String> = a.inputs.iter().map(|p| p.display().to_string()).collect();
        bail!(
            "no scenario file could be read: {} {} no .xml file (CommonRoad scenario XML): \
             nothing written, {untouched}",
            inputs.join(", "),
            if inputs.len() == 1 { "holds" } else { "hold" }
        );
    }
    if s.files == 0 {
        bail!("no scenario file could be read: nothing written, {untouched}");
    }
    if s.closeness.is_empty() {
        print_summary(&s, &a);
        bail!(
            "no safe sequence found in {} scenario files: nothing written, {untouched}",
            s.files
        );
    }
    print_summary(&s, &a);
    Ok(())
}

fn print_summary(s: &ImportSummary, a: &CommonRoadArgs) {
    let c = &s.counts;
    outln!(
        "read {} scenario files, {} road users in {:.1} s",
        s.files,
        s.road_users,
        s.elapsed.as_secs_f64()
    );
    let ignored: Vec<String> = s.ignored.iter().map(|(k, v)| format!("{v} {k}")).collect();
    if !ignored.is_empty() {
        outln!("ignored road users: {}", ignored.join(", "));
    }
    if let Some((file, (x, y))) = s.moved_origins.first() {
        outln!(
            "positions taken relative to a local origin in {} file(s) whose coordinates reach \
             beyond {} km (event files hold f32 positions, which would round them): e.g. {file} \
             minus ({x}, {y}) m",
            s.moved_origins.len(),
            FAR_COORDINATE_M / 1000.0
        );
    }
    if !s.issues.is_empty() {
        outln!(
            "skipped (listed on stderr with the reason): {}",
            s.issues.len()
        );
    }
    outln!(
        "pairs recorded together: {}, interacting: {}; interactions: {} ({} frames, ego: {})",
        c.pairs_overlapping_in_time,
        c.pairs_interacting,
        c.interactions,
        c.interaction_frames,
        a.ego
    );
    outln!(
        "overlapping boxes (recording artefacts) dropped: {} pair-frames",
        c.overlap_frames
    );
    if a.skip_repeats {
        outln!(
            "repeats of an earlier file (--skip-repeats) dropped: {} pair-frames",
            c.repeated_frames
        );
    }
    outln!("by geometry (at each step: seen from the first road user of the pair; per sequence: at closest approach, from its ego):");
    for g in Geometry::ALL {
        let i = geometry_index(g);
        let kept = if a.geometry.contains(g) {
            ""
        } else {
            " (not kept: --geometry)"
        };
        outln!(
            "  {:<9} pair-steps within --max-gap {:>7}, near {:>7}; safe sequences {:>5} ({} frames){kept}",
            g.as_str(),
            c.within_gap_frames[i],
            c.near_frames[i],
            c.sequences_by_geometry[i],
            c.frames_by_geometry[i]
        );
    }
    let destination = if c.sequences == 0 {
        String::new()
    } else {
        format!(" to {}", a.out.display())
    };
    let verb = if c.sequences == 0 { "found" } else { "wrote" };
    // Sequences of a geometry --geometry leaves out passed every rule: not "the rest".
    let left_out: usize = Geometry::ALL
        .into_iter()
        .filter(|g| !a.geometry.contains(*g))
        .map(|g| c.sequences_by_geometry[geometry_index(g)])
        .sum();
    let left_out = if left_out > 0 {
        format!("; {left_out} more of the geometries --geometry leaves out")
    } else {
        String::new()
    };
    outln!(
        "{verb} {} safe sequences with {} frames{destination} (the rest failed |acc| <= {} m/s^2 or the {}-{} s length{left_out})",
        c.sequences,
        c.frames,
        a.max_acc,
        a.min_duration,
        a.max_duration
    );
    for (name, pick) in [("min box gap", 0usize), ("min centre distance", 1)] {
        let mut v: Vec<f32> = s
            .closeness
            .iter()
            .map(|p| if pick == 0 { p.0 } else { p.1 })
            .collect();
        if v.is_empty() {
            continue;
        }
        v.sort_by(f32::total_cmp);
        let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        outln!(
            "{name} per sequence (m): min {:.2}, 10% {:.2}, median {:.2}, 90% {:.2}, max {:.2}",
            q(0.0),
            q(0.1),
            q(0.5),
            q(0.9),
            q(1.0)
        );
    }
}
