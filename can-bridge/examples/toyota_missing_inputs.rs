//! What the inputs a radar does not send cost: lead time and false warnings, measured on a
//! simulated event folder replayed through the Toyota TSS-P map (`maps/toyota_tss_p_radar.toml`)
//! with and without each input, against the project DBC's single-bus log of the same folder
//! (every input as simulated: size, lateral speed, heading, acceleration).
//!
//! `cargo run -p can-bridge --example toyota_missing_inputs -- [--events N] [--seed S]
//!  [--model FILE] [--log-out FILE] [--project-log-out FILE]` prints a Markdown table
//! (docs/can-bridge.md, "What missing inputs cost"); `--log-out` also writes the two-bus candump
//! log (for `score-log --bench`), `--project-log-out` the reference's single-bus log.
//! Only events whose partner the simulated radar sees on every frame up to the reference's first
//! warning (to the end when it does not warn) are compared: what the radar cannot see is a matter
//! of its field of view, not of the map.
use can_bridge::commands::{load_map, ScoringArgs};
use can_bridge::engine::{Engine, EngineConfig, Output};
use can_bridge::map::CompiledMap;
use can_bridge::ModelFile;
use riskscore_data::candump_export::{write_candump, ExportOptions, Layout};
use riskscore_data::events::{EventKind, EventSet};
use std::path::{Path, PathBuf};

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "../tests/common/toyota.rs"]
mod toyota;

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

fn maps() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("maps")
}

/// A map file compiled as `score-log --map FILE --dbc ...` would.
fn compile(map_text: &str, dbc: &[String], tmp: &Path, name: &str) -> CompiledMap {
    let path = tmp.join(format!("{name}.toml"));
    std::fs::write(&path, map_text).unwrap();
    load_map(&ScoringArgs {
        model: PathBuf::new(),
        dbc: dbc.iter().map(PathBuf::from).collect(),
        map: Some(path),
        threshold: None,
        urgent: None,
        hysteresis: 0.0,
        min_on_ms: 500,
        stale_ms: 500,
        latch: false,
        max_problems: 0,
    })
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// First warning onset (us) per event: the onset falls in the event's span on the timeline.
fn onsets(
    model: &ModelFile,
    threshold: f32,
    map: CompiledMap,
    log: &str,
    layout: &Layout,
) -> Vec<Option<u64>> {
    let mut engine =
        Engine::new(model.model().unwrap(), map, EngineConfig::new(threshold)).unwrap();
    let mut first = vec![None; layout.placements.len()];
    for line in log.lines() {
        let rec = can_codec::parse_line(line).unwrap();
        let bus = engine.map().bus_of(rec.iface);
        engine.process_on_bus(rec.timestamp_us, &rec.frame, bus, 0, &mut |o| {
            if let Output::WarningOn { t_us, .. } = o {
                if let Some(k) = layout.placements.iter().position(|p| {
                    t_us >= p.cycle_us[0] && t_us <= p.cycle_us.last().unwrap() + 1_000_000
                }) {
                    first[k].get_or_insert(t_us);
                }
            }
        });
    }
    first
}

struct Row {
    name: String,
    missed: usize,
    extra_on_safe: usize,
    extra_on_conflicts: usize,
    later: Vec<f64>,
}

fn median(v: &mut [f64]) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    (!v.is_empty()).then(|| v[v.len() / 2])
}

fn compare(
    name: &str,
    reference: &[Option<u64>],
    variant: &[Option<u64>],
    compared: &[usize],
    set: &EventSet,
) -> Row {
    let mut row = Row {
        name: name.into(),
        missed: 0,
        extra_on_safe: 0,
        extra_on_conflicts: 0,
        later: Vec::new(),
    };
    for &k in compared {
        match (reference[k], variant[k]) {
            (Some(a), Some(b)) => row.later.push((b as f64 - a as f64) / 1e6),
            (Some(_), None) => row.missed += 1,
            (None, Some(_)) if set.events[k].kind == EventKind::Safe => row.extra_on_safe += 1,
            (None, Some(_)) => row.extra_on_conflicts += 1,
            (None, None) => {}
        }
    }
    row
}

fn main() {
    let events: usize = arg("--events").map_or(200, |v| v.parse().unwrap());
    let seed: u64 = arg("--seed").map_or(7, |v| v.parse().unwrap());
    let model_path = arg("--model").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/drl-default.rsk"),
        PathBuf::from,
    );
    let model = ModelFile::load(&model_path).unwrap();
    let threshold = model.default_threshold().unwrap();
    let tmp = std::env::temp_dir().join(format!("toyota-missing-inputs-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();

    let set = common::simulated_events(events, seed);
    let layout = Layout::new(&set, &ExportOptions::default());
    let mut project_log = Vec::new();
    write_candump(&set, &ExportOptions::default(), &mut project_log).unwrap();
    let project_log = String::from_utf8(project_log).unwrap();
    if let Some(path) = arg("--project-log-out") {
        std::fs::write(&path, &project_log).unwrap();
    }
    let project_map = CompiledMap::project_default().unwrap().1;
    let reference = onsets(&model, threshold, project_map, &project_log, &layout);

    let car = toyota::ToyotaCar::new(toyota::RadarModel::default());
    let encoded = car.encode(&set);
    if let Some(path) = arg("--log-out") {
        std::fs::write(&path, &encoded.log).unwrap();
    }
    let compared: Vec<usize> = (0..set.events.len())
        .filter(|&k| {
            let until = reference[k].unwrap_or(u64::MAX);
            encoded.seen[k]
                .iter()
                .zip(&layout.placements[k].cycle_us)
                .all(|(s, c)| *s || *c > until)
        })
        .collect();
    let trucks: Vec<usize> = compared
        .iter()
        .copied()
        .filter(|&k| set.events[k].dims.length_partner > 6.0)
        .collect();

    let dbc = maps().join("dbc");
    let bound = vec![
        format!(
            "can0={}",
            dbc.join("toyota_new_mc_pt_generated.dbc").display()
        ),
        "can0=builtin:riskscore".to_string(),
        format!("can1={}", dbc.join("toyota_adas.dbc").display()),
    ];
    let shipped = std::fs::read_to_string(maps().join("toyota_tss_p_radar.toml")).unwrap();
    let yaw_line = "yaw_rate = { message = \"KINEMATICS\", signal = \"YAW_RATE\", factor = 0.017453292519943295, dbc_range = false }";
    assert!(shipped.contains(yaw_line));
    let toyota_variants = [
        (
            "Toyota map as shipped (yaw rate, 200 ms window)",
            shipped.clone(),
        ),
        (
            "no yaw rate (derived lateral speed not compensated)",
            shipped.replace(yaw_line, ""),
        ),
        (
            "motion window 100 ms (new tracks scored after 100 ms)",
            shipped.replace("motion_window_ms = 200", "motion_window_ms = 100"),
        ),
        (
            "no relative acceleration (companion slots not read)",
            shipped
                .replace("accel = { companion = true, signal = \"REL_ACCEL\" }", "")
                .replace("accel_relative = true", ""),
        ),
    ];
    let mut rows = Vec::new();
    let mut truck_rows = Vec::new();
    for (i, (name, text)) in toyota_variants.iter().enumerate() {
        let map = compile(text, &bound, &tmp, &format!("toyota{i}"));
        let got = onsets(&model, threshold, map, &encoded.log, &layout);
        rows.push(compare(name, &reference, &got, &compared, &set));
        if i == 0 {
            truck_rows.push(compare(name, &reference, &got, &trucks, &set));
        }
    }
    // The project DBC's log scored without the partner size (default 4.5 m x 1.8 m box): what a
    // radar that sends no size costs on its own, for the trucks.
    let no_size = can_bridge::map::DEFAULT_MAP
        .replace(
            "length = { message = \"OBJECT_SIZE\", signal = \"ObjLength\" }",
            "",
        )
        .replace(
            "width = { message = \"OBJECT_SIZE\", signal = \"ObjWidth\" }",
            "",
        )
        .replace(", OBJECT_SIZE = \"ObjId\"", "");
    assert_ne!(
        no_size,
        can_bridge::map::DEFAULT_MAP,
        "the project map's size lines moved"
    );
    let map = compile(&no_size, &["builtin:riskscore".into()], &tmp, "nosize");
    let got = onsets(&model, threshold, map, &project_log, &layout);
    truck_rows.push(compare(
        "project DBC without the partner size (default 4.5 m car)",
        &reference,
        &got,
        &trucks,
        &set,
    ));

    let warned = compared.iter().filter(|&&k| reference[k].is_some()).count();
    println!(
        "{} simulated events (seed {seed}), model {} at its default threshold {threshold}; {} compared (the radar sees the partner up to the reference's onset), {warned} of them warn in the reference",
        set.events.len(),
        model_path.display(),
        compared.len()
    );
    let print = |title: &str, rows: &mut [Row]| {
        println!("\n{title}\n");
        println!("| variant | warned in both | onset later than reference: median / worst (s) | missed warnings | extra warnings on safe events | extra on crash/near-crash |");
        println!("|---|---|---|---|---|---|");
        for r in rows.iter_mut() {
            let worst = r.later.iter().copied().fold(f64::NAN, |a, b| {
                if b.abs() > a.abs() || a.is_nan() {
                    b
                } else {
                    a
                }
            });
            let n = r.later.len();
            println!(
                "| {} | {n} | {} / {} | {} | {} | {} |",
                r.name,
                median(&mut r.later).map_or("-".into(), |m| format!("{m:+.2}")),
                if worst.is_nan() {
                    "-".into()
                } else {
                    format!("{worst:+.2}")
                },
                r.missed,
                r.extra_on_safe,
                r.extra_on_conflicts
            );
        }
    };
    print(
        "All compared events (reference: the project DBC's log, every input as simulated)",
        &mut rows,
    );
    print(
        &format!(
            "Trucks only ({} compared events with a partner longer than 6 m)",
            trucks.len()
        ),
        &mut truck_rows,
    );
    let _ = std::fs::remove_dir_all(&tmp);
}
