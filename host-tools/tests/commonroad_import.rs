//! `riskctl import commonroad` and `riskscore_data::import::commonroad`: parsing the 2020a and 2018b
//! layouts, the unit conversions, the interaction rules (near, overlap split, ego choice, safe
//! cut), located error messages, and an imported folder that loads with zero issues.
//!
//! The scenarios in tests/data/commonroad are closed forms (make_scenarios.py), so every expected
//! number below is computed by hand from them.
use std::path::{Path, PathBuf};
use std::process::Command;

use riskscore_data::events::{load_events, prepare_sequences, PrepareConfig};
use riskscore_data::import::commonroad::{
    import_to_dir, parse_scenario, read_event_geometries, read_scenario, safe_interactions,
    scenario_of_event_id, vehicle_state, EgoChoice, Ignored, InteractionRules, Problem,
};

mod common;
const RISKCTL: &str = env!("CARGO_BIN_EXE_riskctl");

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/commonroad")
        .join(name)
}

const MERGE: &str = "ZAM_Merge-1_1_T-1.xml";
const LEGACY: &str = "ZAM_Legacy-1_1_T-1.xml";

/// The default rules with one event per interaction (the ego is the road user behind).
fn follower() -> InteractionRules {
    InteractionRules {
        ego: EgoChoice::Follower,
        ..InteractionRules::default()
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn reads_the_2020a_layout_and_ignores_what_is_not_a_vehicle_track() {
    let s = read_scenario(&data(MERGE)).unwrap();
    assert_eq!(s.id, "ZAM_Merge-1_1_T-1");
    assert_eq!(s.version, "2020a");
    assert_eq!(s.dt, 0.1);
    let ids: Vec<&str> = s.tracks.iter().map(|t| t.id.as_str()).collect();
    assert_eq!(ids, ["10", "20", "30", "70", "40"]);
    assert!(s.issues.is_empty(), "{:?}", s.issues);
    assert_eq!(
        s.ignored,
        [
            ("60".to_string(), Ignored::Static),
            ("50".to_string(), Ignored::Type("pedestrian".into()))
        ]
    );
    let truck = &s.tracks[1];
    assert_eq!(
        (truck.kind.as_str(), truck.length, truck.width),
        ("truck", 12.0, 2.5)
    );
    assert_eq!(truck.states.len(), 31);
    let (s0, s30) = (truck.states[0], truck.states[30]);
    assert_eq!((s0.step, s30.step), (0, 30));
    // Truck: 20 m along heading 0.5 rad, 10 m/s, -0.3 m/s^2 recorded.
    assert!(close(s0.x, 20.0 * 0.5f64.cos(), 1e-4) && close(s0.y, 20.0 * 0.5f64.sin(), 1e-4));
    assert_eq!((s0.orientation, s0.speed, s0.acc), (0.5, 10.0, -0.3));
    assert!(close(s30.speed, 9.1, 1e-9));
    // Car 40 has no <acceleration>: derived from its speed 8 + 1.0 t.
    for st in &s.tracks[4].states {
        assert!(close(st.acc, 1.0, 1e-6), "{st:?}");
    }
}

#[test]
fn reads_the_2018b_layout() {
    let s = read_scenario(&data(LEGACY)).unwrap();
    assert_eq!(s.version, "2018b");
    let ids: Vec<&str> = s.tracks.iter().map(|t| t.id.as_str()).collect();
    assert_eq!(ids, ["1", "2"]);
    assert_eq!(s.ignored, [("3".to_string(), Ignored::Static)]);
    let (found, counts) = safe_interactions(&s, &follower());
    assert_eq!(counts.sequences, 1);
    let e = &found[0];
    assert_eq!(e.event.id, "ZAM_Legacy-1_1_T-1/1-2@0#0");
    // Side by side in adjacent lanes: 11 m longitudinal and 1.5 m lateral between the boxes.
    assert!(
        close(f64::from(e.min_gap), 11.0f64.hypot(1.5), 1e-3),
        "{}",
        e.min_gap
    );
    assert!(close(
        f64::from(e.min_centre_distance),
        15.0f64.hypot(3.5),
        1e-3
    ));
}

#[test]
fn converts_speed_along_the_heading_to_world_velocity() {
    let s = read_scenario(&data(MERGE)).unwrap();
    let car = &s.tracks[0];
    let v = vehicle_state(&car.states[0], car.length, car.width);
    // 10 m/s at 0.5 rad: vx = 10 cos 0.5 = 8.7758256, vy = 10 sin 0.5 = 4.7942554.
    assert!(close(f64::from(v.vx), 8.775_825_6, 1e-5), "{v:?}");
    assert!(close(f64::from(v.vy), 4.794_255_4, 1e-5), "{v:?}");
    assert!(
        close(f64::from(v.hx), 0.877_582_56, 1e-6) && close(f64::from(v.hy), 0.479_425_54, 1e-6)
    );
    assert_eq!(
        (v.x, v.y, v.acc, v.length, v.width),
        (0.0, 0.0, 0.2, 4.0, 1.8)
    );
}

#[test]
fn interaction_rules_pick_near_pairs_split_at_overlaps_and_choose_the_follower() {
    let s = read_scenario(&data(MERGE)).unwrap();
    let (found, c) = safe_interactions(&s, &follower());
    // 5 tracks recorded at the same time: 10 pairs. Near: 10 behind the truck 20 (12 m gap) and
    // 70 behind 30 (2 m gap) two lanes away from the others.
    assert_eq!(c.pairs_overlapping_in_time, 10);
    assert_eq!(c.pairs_interacting, 2);
    // 70/30 overlap at steps 10..=14: dropped, the interaction split into 0..=9 and 15..=40.
    assert_eq!(c.overlap_frames, 5);
    assert_eq!(c.interactions, 3);
    assert_eq!(c.interaction_frames, 31 + 10 + 26);
    let ids: Vec<&str> = found.iter().map(|f| f.event.id.as_str()).collect();
    // The 0.9 s piece before the overlap is too short; the rest are whole (|acc| <= 0.3).
    assert_eq!(
        ids,
        [
            "ZAM_Merge-1_1_T-1/10-20@0#0",
            "ZAM_Merge-1_1_T-1/70-30@15#0"
        ]
    );
    assert_eq!((c.sequences, c.frames), (2, 31 + 26));
    let truck = &found[0];
    assert_eq!((truck.event.t_start, truck.event.t_end), (0.0, 3.0));
    let d = truck.event.dims;
    assert_eq!(
        (d.length_ego, d.width_ego, d.length_partner, d.width_partner),
        (4.0, 1.8, 12.0, 2.5)
    );
    // Gap 12 m closes by (0.2 + 0.3) / 2 * 3^2 = 2.25 m over 3 s.
    assert!(
        close(f64::from(truck.min_gap), 9.75, 2e-3),
        "{}",
        truck.min_gap
    );
    let f = &truck.event.frames[10];
    assert_eq!(f.time, 1.0);
    assert_eq!((f.ego.acc, f.partner.acc), (0.2, -0.3));
    let pair = &found[1];
    assert_eq!((pair.event.t_start, pair.event.t_end), (1.5, 4.0));
    assert!(close(f64::from(pair.min_gap), 2.0, 1e-3));

    // Both orders (the default): each interaction twice, ego and partner swapped.
    let (found, both) = safe_interactions(&s, &InteractionRules::default());
    assert_eq!(both.interaction_frames, 2 * c.interaction_frames);
    let ids: Vec<&str> = found.iter().map(|f| f.event.id.as_str()).collect();
    assert_eq!(
        ids,
        [
            "ZAM_Merge-1_1_T-1/10-20@0#0",
            "ZAM_Merge-1_1_T-1/20-10@0#0",
            "ZAM_Merge-1_1_T-1/30-70@15#0",
            "ZAM_Merge-1_1_T-1/70-30@15#0"
        ]
    );
    assert_eq!(found[1].event.frames[0].ego.length, 12.0);

    // Gap threshold below the truck's 9.75 m: only 70/30 remains.
    let tight = InteractionRules {
        max_gap: 5.0,
        ..follower()
    };
    assert_eq!(safe_interactions(&s, &tight).1.pairs_interacting, 1);
    // Lateral threshold above the 12 m lane offset: 10 and 20 now interact with 30 and 70 too.
    let wide = InteractionRules {
        max_lateral: 13.0,
        ..follower()
    };
    assert_eq!(safe_interactions(&s, &wide).1.pairs_interacting, 6);
    // Minimum duration 3 s: the 2.5 s piece of 70/30 is dropped, the 3 s one kept.
    let long = InteractionRules {
        safe: PrepareConfig {
            safe_min_duration: 3.0,
            ..PrepareConfig::default()
        },
        ..follower()
    };
    let (found, _) = safe_interactions(&s, &long);
    assert_eq!(found.len(), 1);
    // Acceleration limit below the truck's 0.3 m/s^2: no calm frame for that pair.
    let calm = InteractionRules {
        safe: PrepareConfig {
            safe_max_abs_acc: 0.25,
            ..PrepareConfig::default()
        },
        ..follower()
    };
    let (found, _) = safe_interactions(&s, &calm);
    assert_eq!(found.len(), 1);
    assert!(found[0].event.id.contains("/70-30@"));
}

/// A minimal 2020a file: obstacle 41 is good, obstacle 42 has `state` (the 3rd trajectory state
/// replaced by `bad_state`).
fn two_obstacles(bad_state: &str) -> String {
    let state = |step: i64, x: f64| {
        format!(
            "<state><position><point><x>{x}</x><y>0</y></point></position>\
             <orientation><exact>0</exact></orientation><time><exact>{step}</exact></time>\
             <velocity><exact>10</exact></velocity></state>\n"
        )
    };
    let obstacle = |id: u32, y: f64, bad: Option<&str>| {
        let mut s = format!(
            "<dynamicObstacle id=\"{id}\">\n<type>car</type>\n\
             <shape><rectangle><length>4</length><width>2</width></rectangle></shape>\n\
             <initialState><position><point><x>0</x><y>{y}</y></point></position>\
             <orientation><exact>0</exact></orientation><time><exact>0</exact></time>\
             <velocity><exact>10</exact></velocity></initialState>\n<trajectory>\n"
        );
        for step in 1..=4 {
            match (step, bad) {
                (3, Some(b)) => s.push_str(&format!("{b}\n")),
                _ => s.push_str(&state(step, step as f64)),
            }
        }
        s.push_str("</trajectory>\n</dynamicObstacle>\n");
        s
    };
    format!(
        "<?xml version=\"1.0\"?>\n<commonRoad commonRoadVersion=\"2020a\" timeStepSize=\"0.1\">\n{}{}</commonRoad>\n",
        obstacle(41, 0.0, None),
        obstacle(42, 8.0, Some(bad_state))
    )
}

fn line_of(text: &str, needle: &str) -> u32 {
    let at = text.find(needle).expect("needle");
    text[..at].matches('\n').count() as u32 + 1
}

#[test]
fn a_malformed_road_user_is_skipped_with_file_line_obstacle_and_element() {
    let bad = "<state><position><point><x>3</x><y>8</y></point></position>\
               <orientation><exact>0</exact></orientation><time><exact>3</exact></time></state>";
    let text = two_obstacles(bad);
    let s = parse_scenario(&text, "USA_US101-1_1_T-1.xml", "USA_US101-1_1_T-1").unwrap();
    let ids: Vec<&str> = s.tracks.iter().map(|t| t.id.as_str()).collect();
    assert_eq!(ids, ["41"], "the good obstacle is kept");
    assert_eq!(s.issues.len(), 1);
    let line = line_of(&text, bad);
    assert_eq!(
        s.issues[0].to_string(),
        format!(
            "USA_US101-1_1_T-1.xml:{line}: <dynamicObstacle id=42> <state> #3: missing <velocity>"
        )
    );

    let cases: [(&str, &str, Problem); 6] = [
        // Values the event folder refuses (a broken export): the road user was imported and then
        // every event it was in was refused by the loader.
        (
            "<state><position><point><x>3</x><y>8</y></point></position>\
             <orientation><exact>0</exact></orientation><time><exact>3</exact></time>\
             <velocity><exact>1e30</exact></velocity></state>",
            "<state> #3 <velocity> <exact>: 1000000000000000000000000000000 m/s is outside the \
             physical range [-100, 100] m/s an event folder accepts",
            Problem::Unphysical {
                value: 1e30,
                min: -100.0,
                max: 100.0,
                unit: "m/s",
            },
        ),
        (
            "<state><position><point><x>3e9</x><y>8</y></point></position>\
             <orientation><exact>0</exact></orientation><time><exact>3</exact></time>\
             <velocity><exact>10</exact></velocity></state>",
            "<state> #3 <position> <point> <x>: 3000000000 m is outside",
            Problem::Unphysical {
                value: 3e9,
                min: -1e8,
                max: 1e8,
                unit: "m",
            },
        ),
        (
            "<state><position><point><x>3O</x><y>8</y></point></position>\
             <orientation><exact>0</exact></orientation><time><exact>3</exact></time>\
             <velocity><exact>10</exact></velocity></state>",
            "<state> #3 <position> <point> <x>: `3O` is not a finite number",
            Problem::BadNumber("3O".into()),
        ),
        (
            "<state><position><point><x>3</x><y>8</y></point></position>\
             <orientation><intervalStart>0</intervalStart><intervalEnd>1</intervalEnd></orientation>\
             <time><exact>3</exact></time><velocity><exact>10</exact></velocity></state>",
            "<state> #3 <orientation>: an interval",
            Problem::Interval,
        ),
        (
            "<state><position><point><x>3</x><y>8</y></point></position>\
             <orientation><exact>0</exact></orientation><time><exact>2</exact></time>\
             <velocity><exact>10</exact></velocity></state>",
            "<state> #3: time step 2 does not follow step 2",
            Problem::StepOrder {
                step: 2,
                previous: 2,
            },
        ),
        (
            "<state><position><lanelet ref=\"3\"/></position>\
             <orientation><exact>0</exact></orientation><time><exact>3</exact></time>\
             <velocity><exact>10</exact></velocity></state>",
            "<state> #3 <position>: missing <point>",
            Problem::Missing("point"),
        ),
    ];
    for (bad, message, problem) in cases {
        let s = parse_scenario(&two_obstacles(bad), "f.xml", "f").unwrap();
        assert_eq!(s.tracks.len(), 1, "{bad}");
        let issue = &s.issues[0];
        assert_eq!(issue.problem, problem);
        let text = issue.to_string();
        assert!(
            text.starts_with("f.xml:") && text.contains("<dynamicObstacle id=42>"),
            "{text}"
        );
        assert!(text.contains(message), "{text} lacks {message}");
    }
}

/// A 35 m long "car" was imported, and every event it was in refused by the loader later.
#[test]
fn a_road_user_of_unphysical_size_is_skipped() {
    let text = two_obstacles(
        "<state><position><point><x>3</x><y>8</y></point></position>\
         <orientation><exact>0</exact></orientation><time><exact>3</exact></time>\
         <velocity><exact>10</exact></velocity></state>",
    )
    .replacen("<length>4</length>", "<length>35</length>", 1);
    let s = parse_scenario(&text, "f.xml", "f").unwrap();
    let ids: Vec<&str> = s.tracks.iter().map(|t| t.id.as_str()).collect();
    assert_eq!(ids, ["42"], "the good obstacle is kept");
    assert_eq!(
        s.issues[0].problem,
        Problem::Unphysical {
            value: 35.0,
            min: 0.5,
            max: 30.0,
            unit: "m"
        }
    );
    let issue = s.issues[0].to_string();
    assert!(
        issue.starts_with("f.xml:")
            && issue
                .contains("<dynamicObstacle id=41> <shape> <rectangle> <length>: 35 m is outside"),
        "{issue}"
    );
    // The bounds themselves are physical, as the event folder has them (0.3 m wide, in f32).
    let narrow = text
        .replacen("<length>35</length>", "<length>4</length>", 1)
        .replacen("<width>2</width>", "<width>0.3</width>", 1);
    let s = parse_scenario(&narrow, "f.xml", "f").unwrap();
    assert_eq!(s.tracks.len(), 2, "{:?}", s.issues);
    let wide = narrow.replacen("<width>0.3</width>", "<width>0.29</width>", 1);
    let issue = parse_scenario(&wide, "f.xml", "f").unwrap().issues[0].to_string();
    assert!(
        issue.contains("0.29 m is outside the physical range [0.3, 5] m"),
        "{issue}"
    );
}

#[test]
fn a_file_that_is_not_a_scenario_is_one_error() {
    let err = parse_scenario(
        "<commonRoad timeStepSize=\"0.1\">\n<a></b>\n</commonRoad>",
        "x.xml",
        "x",
    )
    .unwrap_err();
    assert!(matches!(err.problem, Problem::Xml(_)), "{err}");
    assert!(
        err.to_string().starts_with("x.xml:2: not well-formed XML"),
        "{err}"
    );
    let err = parse_scenario("<osm/>", "x.xml", "x").unwrap_err();
    assert_eq!(
        err.to_string(),
        "x.xml:1: root element is <osm>, not <commonRoad>"
    );
    let err = parse_scenario("<commonRoad/>", "x.xml", "x").unwrap_err();
    assert_eq!(
        err.to_string(),
        "x.xml:1: <commonRoad>: missing attribute `timeStepSize`"
    );
    let err = parse_scenario("<commonRoad timeStepSize=\"-1\"/>", "x.xml", "x").unwrap_err();
    assert!(
        err.to_string().contains("`-1` is not a positive number"),
        "{err}"
    );
}

#[test]
fn the_imported_folder_loads_with_zero_issues_and_splits_by_scenario() {
    let out = tempfile::tempdir().unwrap();
    let rules = follower();
    let summary = import_to_dir(&[data("")], out.path(), &rules).unwrap();
    assert_eq!(summary.files, 2);
    assert_eq!(summary.road_users, 7);
    assert!(summary.issues.is_empty(), "{:?}", summary.issues);
    assert_eq!(summary.ignored.get(&Ignored::Static), Some(&2));
    assert_eq!(summary.counts.sequences, 3);
    assert_eq!(summary.closeness.len(), 3);

    let frames = std::fs::read_to_string(out.path().join("frames.csv")).unwrap();
    assert!(frames.lines().next().unwrap().ends_with(",acc_sur"));
    let (set, issues) = load_events(out.path()).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    assert_eq!(set.len(), 3);
    assert_eq!(set.counts().safe, 3);
    // The recorded partner acceleration survives the round trip.
    let truck = set.get("ZAM_Merge-1_1_T-1/10-20@0#0").unwrap();
    assert!(truck.frames.iter().all(|f| f.partner.acc == -0.3));
    let (seqs, prep) = prepare_sequences(&set, &PrepareConfig::default());
    assert!(prep.is_empty(), "{prep:?}");
    assert_eq!(seqs.len(), 3);
    let mut scenarios: Vec<&str> = set
        .iter()
        .map(|e| scenario_of_event_id(&e.id).unwrap())
        .collect();
    scenarios.dedup();
    assert_eq!(scenarios, ["ZAM_Legacy-1_1_T-1", "ZAM_Merge-1_1_T-1"]);

    // The same file twice is read once, the second naming skipped with an issue.
    let again = import_to_dir(&[data(MERGE), data(MERGE)], out.path(), &rules).unwrap();
    assert_eq!(again.files, 1);
    assert!(matches!(again.issues[0].problem, Problem::SameFile { .. }));
    // Two files with one stem would clash: the second is skipped with an issue.
    let copy = tempfile::tempdir().unwrap();
    std::fs::copy(data(MERGE), copy.path().join(MERGE)).unwrap();
    let clash = import_to_dir(&[data(MERGE), copy.path().join(MERGE)], out.path(), &rules).unwrap();
    assert_eq!(clash.files, 1);
    assert!(matches!(
        clash.issues[0].problem,
        Problem::DuplicateScenario { .. }
    ));
}

#[test]
fn cli_imports_prints_a_summary_and_teaches_its_rules() {
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().join("ev");
    let o = Command::new(RISKCTL)
        .args(["import", "commonroad", "--out"])
        .arg(&dir)
        .arg(data(MERGE))
        .arg(data(LEGACY))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        stdout.contains("read 2 scenario files, 7 road users"),
        "{stdout}"
    );
    assert!(
        stdout.contains("wrote 6 safe sequences with 166 frames"),
        "{stdout}"
    );
    assert!(stdout.contains("1 type `pedestrian`"), "{stdout}");
    let (set, issues) = load_events(&dir).unwrap();
    assert!(issues.is_empty() && set.len() == 6);

    let bad = out.path().join("bad.xml");
    std::fs::write(&bad, "<commonRoad>").unwrap();
    let o = Command::new(RISKCTL)
        .args(["import", "commonroad", "--out"])
        .arg(&dir)
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("bad.xml:1: not well-formed XML"),
        "{stderr}"
    );

    let help = Command::new(RISKCTL)
        .args(["import", "commonroad", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for needle in [
        "--max-gap",
        "[default: 30]",
        "--ego",
        "[default: both]",
        "overlap",
        "{scenario}/",
        "--geometry",
        "following,adjacent,crossing,oncoming",
        "--max-approach",
        "[default: 10]",
        "--horizon",
        "[default: 3]",
        "closest approach",
        "--smooth-speed",
        "--skip-repeats",
        "scenarios.csv",
    ] {
        assert!(help.contains(needle), "help lacks {needle}:\n{help}");
    }
}

#[test]
fn cli_filters_by_geometry_counts_each_and_refuses_an_unknown_one() {
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().join("ev");
    let run = |extra: &[&str]| {
        Command::new(RISKCTL)
            .args(["import", "commonroad", "--out"])
            .arg(&dir)
            .args(extra)
            .arg(data(MERGE))
            .output()
            .unwrap()
    };
    // The merge fixture is all same-way traffic: 10 behind the truck 20 (following), 70 behind
    // 30 in its lane (following).
    let o = run(&["--geometry", "following"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}");
    assert!(
        stdout.contains("following pair-steps within --max-gap"),
        "{stdout}"
    );
    assert!(stdout.contains("wrote 4 safe sequences"), "{stdout}");
    // Only crossing partners: none here, so nothing is written and the folder is left alone.
    let o = run(&["--geometry", "crossing,oncoming"]);
    assert!(!o.status.success());
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("(not kept: --geometry)"), "{stdout}");
    // The 4 following sequences passed every rule: the summary said they failed the acceleration
    // or length rule.
    assert!(
        stdout.contains("found 0 safe sequences")
            && stdout.contains("; 4 more of the geometries --geometry leaves out)"),
        "{stdout}"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("no safe sequence found"), "{stderr}");
    assert_eq!(load_events(&dir).unwrap().0.len(), 4);
    // A misspelt geometry is refused before anything is read, naming it and the choices.
    let o = run(&["--geometry", "following,sideways"]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("`sideways` is not a geometry") && stderr.contains("--geometry"),
        "{stderr}"
    );
    let o = run(&["--smooth-speed=-1"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--smooth-speed"));
}

/// The committed urban extract (data/ngsim-urban-safe, PROVENANCE.md): loads clean, prepares
/// whole, both cities, every event's geometry in scenarios.csv as PROVENANCE.md counts them.
#[test]
fn the_shipped_urban_extract_loads_clean_with_both_cities_and_every_geometry() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ngsim-urban-safe");
    let (set, issues) = load_events(&dir).unwrap();
    assert!(issues.is_empty(), "{:?}", &issues[..issues.len().min(5)]);
    assert_eq!((set.len(), set.counts().safe), (664, 664));
    let (seqs, prep) = prepare_sequences(&set, &PrepareConfig::default());
    assert!(prep.is_empty(), "{:?}", &prep[..prep.len().min(5)]);
    assert_eq!(seqs.len(), 664);
    let geometries = read_event_geometries(&dir).unwrap().unwrap();
    let mut by_city_and_geometry = std::collections::BTreeMap::new();
    for e in set.iter() {
        let scenario = scenario_of_event_id(&e.id).unwrap();
        let city = if scenario.starts_with("USA_Lanker-") {
            "Lankershim"
        } else if scenario.starts_with("USA_Peach-") {
            "Peachtree"
        } else {
            panic!("{} is from neither city", e.id)
        };
        *by_city_and_geometry
            .entry((city, geometries[&e.id].as_str()))
            .or_insert(0) += 1;
    }
    let want = [
        (("Lankershim", "adjacent"), 323),
        (("Lankershim", "crossing"), 12),
        (("Lankershim", "following"), 191),
        (("Lankershim", "oncoming"), 10),
        (("Peachtree", "adjacent"), 69),
        (("Peachtree", "crossing"), 2),
        (("Peachtree", "following"), 31),
        (("Peachtree", "oncoming"), 26),
    ];
    assert_eq!(by_city_and_geometry.into_iter().collect::<Vec<_>>(), want);
}

/// The committed NGSIM extract (data/ngsim-us101-safe, PROVENANCE.md): loads with zero issues and
/// every event survives preparation whole, so training and evaluation see all of it.
#[test]
fn the_shipped_ngsim_extract_loads_clean_and_prepares_whole() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ngsim-us101-safe");
    let (set, issues) = load_events(&dir).unwrap();
    assert!(issues.is_empty(), "{:?}", &issues[..issues.len().min(5)]);
    assert_eq!((set.len(), set.counts().safe), (376, 376));
    let frames: usize = set.iter().map(|e| e.frames.len()).sum();
    assert_eq!(frames, 10_682);
    let (seqs, prep) = prepare_sequences(&set, &PrepareConfig::default());
    assert!(prep.is_empty(), "{:?}", &prep[..prep.len().min(5)]);
    for (s, e) in seqs.iter().zip(set.iter()) {
        assert_eq!(s.frames.len(), e.frames.len(), "{}", e.id);
        let scenario = scenario_of_event_id(&e.id).unwrap();
        assert!(scenario.starts_with("USA_US101-"), "{}", e.id);
    }
}

#[test]
fn a_folder_without_scenario_files_is_named() {
    // An event folder given as the input: it was only "no scenario file could be read".
    let tmp = tempfile::tempdir().unwrap();
    let events = common::simulate(tmp.path());
    let out = tmp.path().join("imported");
    let o = common::riskctl(&[
        "import",
        "commonroad",
        "--out",
        out.to_str().unwrap(),
        events.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(&format!("{} holds no .xml file", events.display())),
        "{err}"
    );
    assert!(!out.exists());
}
