//! Importing city traffic: crossing and oncoming partners from a small CommonRoad file, the
//! per-event geometry in `scenarios.csv`, and the committed NGSIM urban extract regenerating
//! byte for byte from its source file (when the shared data folder is present).
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use riskscore_data::events::{load_events, PrepareConfig};
use riskscore_data::import::commonroad::{
    closest_approach, import_to_dir, read_event_geometries, GeometrySet, InteractionRules,
    PROVENANCE_FILE,
};
use scorer_core::interaction::Geometry;

/// A 2020a scenario: `cars` are (id, x0, y0, heading in degrees, speed), 31 states at 0.1 s.
fn scenario_xml(cars: &[(u32, f64, f64, f64, f64)]) -> String {
    let mut xml = String::from(
        "<?xml version=\"1.0\"?>\n<commonRoad commonRoadVersion=\"2020a\" timeStepSize=\"0.1\">\n",
    );
    for &(id, x0, y0, deg, v) in cars {
        let (sin, cos) = deg.to_radians().sin_cos();
        let state = |tag: &str, step: u32| {
            let t = f64::from(step) * 0.1;
            format!(
                "<{tag}><position><point><x>{}</x><y>{}</y></point></position><orientation><exact>{}</exact></orientation><time><exact>{step}</exact></time><velocity><exact>{v}</exact></velocity><acceleration><exact>0</exact></acceleration></{tag}>\n",
                x0 + v * cos * t,
                y0 + v * sin * t,
                deg.to_radians()
            )
        };
        let _ = write!(
            xml,
            "<dynamicObstacle id=\"{id}\"><type>car</type><shape><rectangle><length>4.5</length><width>1.8</width></rectangle></shape>\n{}<trajectory>\n",
            state("initialState", 0)
        );
        for step in 1..=30 {
            xml.push_str(&state("state", step));
        }
        xml.push_str("</trajectory></dynamicObstacle>\n");
    }
    xml.push_str("</commonRoad>\n");
    xml
}

/// An intersection: 1 drives east; 2 comes the other way 7 m to the side (two lanes over);
/// 3 waits at the crossing street's stop line 8 m south of 1's path; 4 waits in the next
/// crossing street, 20 m south of 1's path and 12 m to the side of 3 (within 30 m of 1's box,
/// but their paths never come within 10 m).
fn intersection(dir: &Path) -> PathBuf {
    let path = dir.join("ZAM_Junction-1_1_T-1.xml");
    let xml = scenario_xml(&[
        (1, -10.0, 0.0, 0.0, 5.0),
        (2, 20.0, 7.0, 180.0, 5.0),
        (3, 8.0, -8.0, 90.0, 0.0),
        (4, 20.0, -20.0, 90.0, 0.0),
    ]);
    std::fs::write(&path, xml).unwrap();
    path
}

#[test]
fn crossing_and_oncoming_partners_are_imported_with_their_geometry() {
    let tmp = tempfile::tempdir().unwrap();
    let input = intersection(tmp.path());
    let out = tmp.path().join("events");
    let summary = import_to_dir(&[input], &out, &InteractionRules::default()).unwrap();
    assert!(summary.issues.is_empty(), "{:?}", summary.issues);
    let (set, issues) = load_events(&out).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    let geometries = read_event_geometries(&out).unwrap().unwrap();
    let mut found: Vec<(&str, Geometry)> = set
        .iter()
        .map(|e| (e.id.as_str(), geometries[&e.id]))
        .collect();
    found.sort();
    // 4 is too far from every path; 2 and 3 never come within 10 m of each other either
    // (2 passes 15 m north of the stop line).
    assert_eq!(
        found,
        [
            ("ZAM_Junction-1_1_T-1/1-2@0#0", Geometry::Oncoming),
            ("ZAM_Junction-1_1_T-1/1-3@0#0", Geometry::Crossing),
            ("ZAM_Junction-1_1_T-1/2-1@0#0", Geometry::Oncoming),
            ("ZAM_Junction-1_1_T-1/3-1@0#0", Geometry::Crossing),
        ]
    );
    // The file agrees with the library's definition on the loaded frames.
    for e in set.iter() {
        let closest = closest_approach(&e.frames).unwrap();
        assert_eq!(closest.geometry, Some(geometries[&e.id]), "{}", e.id);
    }
    let c = &summary.counts;
    assert_eq!(c.sequences_by_geometry, [0, 0, 2, 2]);

    // Only oncoming partners: the crossing ones are counted, not written.
    let oncoming = InteractionRules {
        geometries: GeometrySet::of(&[Geometry::Oncoming]),
        ..InteractionRules::default()
    };
    let out2 = tmp.path().join("oncoming");
    import_to_dir(&[intersection(tmp.path())], &out2, &oncoming).unwrap();
    let (set, _) = load_events(&out2).unwrap();
    let ids: Vec<&str> = set.iter().map(|e| e.id.as_str()).collect();
    assert_eq!(
        ids,
        [
            "ZAM_Junction-1_1_T-1/1-2@0#0",
            "ZAM_Junction-1_1_T-1/2-1@0#0"
        ]
    );
}

#[test]
fn a_bad_geometry_row_is_named_by_file_line_and_column() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join(PROVENANCE_FILE),
        "event_id,scenario,geometry\na/1-2@0#0,a,crossing\na/2-1@0#0,a,sideways\n",
    )
    .unwrap();
    let err = read_event_geometries(tmp.path()).unwrap_err().to_string();
    assert!(err.contains("scenarios.csv:3:"), "{err}");
    assert!(err.contains("column `geometry`: `sideways`"), "{err}");
    // The same line in a Windows file, and after a blank line: the file's own line numbers.
    for (text, line) in [
        (
            "event_id,scenario,geometry\r\na/1-2@0#0,a,crossing\r\na/2-1@0#0,a,sideways\r\n",
            3,
        ),
        (
            "event_id,scenario,geometry\na/1-2@0#0,a,crossing\n\na/2-1@0#0,a,sideways\n",
            4,
        ),
    ] {
        std::fs::write(tmp.path().join(PROVENANCE_FILE), text).unwrap();
        let err = read_event_geometries(tmp.path()).unwrap_err().to_string();
        assert!(err.contains(&format!("scenarios.csv:{line}:")), "{err}");
    }
    // A simulator folder's scenarios.csv has no geometry column: nothing to read, no error.
    std::fs::write(
        tmp.path().join(PROVENANCE_FILE),
        "event_id,kind,family\nsim-1,safe,following\n",
    )
    .unwrap();
    assert!(read_event_geometries(tmp.path()).unwrap().is_none());
    // No file at all (an import made before the column existed).
    let empty = tempfile::tempdir().unwrap();
    assert!(read_event_geometries(empty.path()).unwrap().is_none());
}

/// The repository root (this crate is host-tools/data).
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The rows of `file` in `dir` whose first field starts with `prefix`, header first.
fn rows_of(dir: &Path, file: &str, prefix: &str) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join(file)).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default().to_string();
    std::iter::once(header)
        .chain(lines.filter(|l| l.starts_with(prefix)).map(str::to_string))
        .collect()
}

#[test]
fn the_committed_urban_extract_regenerates_from_its_source() {
    // Peachtree 4_2 is 4_1 twenty steps later in a shifted frame: importing both exercises the
    // repeat detection as the extract's command does (4_1 keeps the shared moments).
    const FILES: [&str; 2] = ["USA_Peach-4_1_T-1", "USA_Peach-4_2_T-1"];
    let shared = repo().join("../shared/data/ngsim-urban");
    let sources: Vec<PathBuf> = FILES
        .iter()
        .map(|f| shared.join(format!("{f}.xml")))
        .collect();
    if let Some(absent) = sources.iter().find(|p| !p.exists()) {
        println!(
            "skipped: {} is absent (the shared data folder is not next to this clone)",
            absent.display()
        );
        return;
    }
    // The options of data/ngsim-urban-safe/PROVENANCE.md.
    let rules = InteractionRules {
        speed_smoothing: 1.0,
        skip_repeats: true,
        ..InteractionRules::default()
    };
    let tmp = tempfile::tempdir().unwrap();
    let summary = import_to_dir(&sources, tmp.path(), &rules).unwrap();
    assert!(summary.counts.repeated_frames > 0, "{:?}", summary.counts);
    let committed = repo().join("data/ngsim-urban-safe");
    for file in ["events.csv", "frames.csv", PROVENANCE_FILE] {
        for scenario in FILES {
            let prefix = format!("{scenario}/");
            let want = rows_of(&committed, file, &prefix);
            let got = rows_of(tmp.path(), file, &prefix);
            assert!(
                want.len() > 1,
                "{file}: the extract has no rows of {scenario}"
            );
            assert_eq!(got.len(), want.len(), "{file}, {scenario}");
            let first_difference = got.iter().zip(&want).position(|(g, w)| g != w);
            assert_eq!(first_difference, None, "{file}, {scenario}: row differs");
        }
    }
    // And the extract is what the library loads: every event whole, none dropped.
    let (set, issues) = load_events(&committed).unwrap();
    assert!(issues.is_empty(), "{issues:?}");
    let geometries: HashMap<String, Geometry> = read_event_geometries(&committed).unwrap().unwrap();
    assert_eq!(geometries.len(), set.len());
    let prepared = riskscore_data::events::prepare_sequences(&set, &PrepareConfig::default());
    assert_eq!(prepared.0.len(), set.len());
}

#[test]
fn orientations_in_degrees_skip_their_road_user_with_its_line() {
    // Car 1 heads 30° with `<orientation>` written as 30 (degrees; 30 rad is 279°), car 2 in
    // radians. The importer builds velocities from orientations, so the event loader's heading
    // check compared the wrong heading with a velocity as wrong as itself: nothing was said.
    let tmp = tempfile::tempdir().unwrap();
    let xml = scenario_xml(&[(1, 0.0, 0.0, 30.0, 10.0), (2, 0.0, 5.0, 30.0, 10.0)]);
    let radians = format!("<exact>{}</exact></orientation>", 30f64.to_radians());
    let first_car_end = xml.find("</dynamicObstacle>").unwrap();
    let xml = format!(
        "{}{}",
        xml[..first_car_end].replace(&radians, "<exact>30</exact></orientation>"),
        &xml[first_car_end..]
    );
    let input = tmp.path().join("ZAM_Degrees-1_1_T-1.xml");
    std::fs::write(&input, xml).unwrap();
    let summary = import_to_dir(
        &[input],
        &tmp.path().join("out"),
        &InteractionRules::default(),
    )
    .unwrap();
    let texts: Vec<String> = summary.issues.iter().map(ToString::to_string).collect();
    assert_eq!(texts.len(), 1, "{texts:?}");
    assert!(
        texts[0].contains("ZAM_Degrees-1_1_T-1.xml:3: <dynamicObstacle id=1>")
            && texts[0].contains("off the direction the positions move in on 30 of the 30 steps")
            && texts[0].contains("degrees instead of radians"),
        "{}",
        texts[0]
    );
    assert_eq!(summary.road_users, 1);
}
