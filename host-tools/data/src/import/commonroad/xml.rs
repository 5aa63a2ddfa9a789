//! Reading a CommonRoad scenario file (XML) into the recorded tracks of its road users.
//!
//! Supported layouts (the element names decide, not the version attribute):
//! - 2020a (what CommonRoad's own tools still write as XML in their 2023 releases, and the
//!   NGSIM/highD benchmark files): `<commonRoad timeStepSize=…>` with `<dynamicObstacle id=…>`
//!   children holding `<type>`, `<shape><rectangle>`, `<initialState>` and `<trajectory><state>…`.
//! - 2018b: the same states, but obstacles are `<obstacle id=…>` with `<role>dynamic</role>`.
//!
//! Ignored (counted, never an error): `<staticObstacle>`, 2018b static obstacles,
//! `<environmentObstacle>`, `<phantomObstacle>`, `<planningProblem>`, lanelets and traffic rules,
//! road users of a type that is not a vehicle (pedestrian, train, unknown, …), non-rectangular
//! shapes, obstacles with an `<occupancySet>` prediction instead of a recorded `<trajectory>` and
//! obstacles with an `<initialState>` only (no prediction: the schema allows it).
//! A malformed road user is skipped with an [`Issue`] naming the file, line, obstacle id and
//! element; the rest of the file is still read.
use std::path::Path;

use roxmltree::{Document, Node};

use super::derivative::speed_derivative;

/// Vehicle types whose tracks are imported (CommonRoad `obstacleTypeDynamic` spelling).
pub const VEHICLE_TYPES: [&str; 7] = [
    "car",
    "truck",
    "bus",
    "taxi",
    "priorityVehicle",
    "motorcycle",
    "bicycle",
];

/// One recorded state of a road user (box centre, SI units, world frame of the scenario).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackState {
    /// Integer time step; seconds = step x the scenario's `timeStepSize`.
    pub step: i64,
    pub x: f64,
    pub y: f64,
    /// Heading (rad), counter-clockwise from the x axis.
    pub orientation: f64,
    /// Speed along the heading (m/s).
    pub speed: f64,
    /// Acceleration along the heading (m/s^2): recorded, or derived when the file has none.
    pub acc: f64,
}

/// The recorded trajectory of one road user.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    pub id: String,
    pub kind: String,
    pub length: f32,
    pub width: f32,
    /// Strictly increasing in `step` (gaps are possible).
    pub states: Vec<TrackState>,
}

/// Why a road user of a file is not imported (not an error: recorded on purpose).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Ignored {
    /// `<staticObstacle>` or 2018b `<role>static</role>`.
    Static,
    /// `<environmentObstacle>` / `<phantomObstacle>`.
    Environment,
    /// A type outside [`VEHICLE_TYPES`] (the type is kept).
    Type(String),
    /// A shape other than one `<rectangle>`.
    NotRectangle,
    /// An `<occupancySet>` prediction, not a recorded trajectory.
    NoTrajectory,
    /// An `<initialState>` and no prediction at all (valid CommonRoad: the trajectory is
    /// optional): one recorded moment, too short for any interaction.
    InitialStateOnly,
}

impl std::fmt::Display for Ignored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Ignored::Static => f.write_str("static obstacle"),
            Ignored::Environment => f.write_str("environment/phantom obstacle"),
            Ignored::Type(t) => write!(f, "type `{t}`"),
            Ignored::NotRectangle => f.write_str("shape is not one rectangle"),
            Ignored::NoTrajectory => f.write_str("occupancy set, no trajectory"),
            Ignored::InitialStateOnly => f.write_str("initial state only, no trajectory"),
        }
    }
}

/// A scenario file's road users.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// The file stem: the scenario id used in event ids.
    pub id: String,
    /// `commonRoadVersion` attribute (empty when absent).
    pub version: String,
    /// `timeStepSize` (s).
    pub dt: f64,
    /// Subtracted from every position of `tracks` (m): `(0, 0)` unless the file's coordinates
    /// reach beyond [`FAR_COORDINATE_M`] (see [`local_origin`]).
    pub origin: (f64, f64),
    pub tracks: Vec<Track>,
    /// Road users deliberately not imported, with the reason.
    pub ignored: Vec<(String, Ignored)>,
    /// Road users skipped because an element is malformed.
    pub issues: Vec<Issue>,
}

/// What is wrong in a file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Problem {
    #[error("cannot read the file: {0}")]
    Io(String),
    #[error("not well-formed XML: {0}")]
    Xml(String),
    #[error("a <!DOCTYPE ...> declaration is not read (its entities could expand without bound): remove that line; CommonRoad files have none")]
    Doctype,
    #[error("root element is <{0}>, not <commonRoad>")]
    NotCommonRoad(String),
    #[error("missing attribute `{0}`")]
    MissingAttribute(&'static str),
    #[error("attribute `{attribute}`: `{text}` is not a positive number")]
    BadAttribute {
        attribute: &'static str,
        text: String,
    },
    #[error("missing <{0}>")]
    Missing(&'static str),
    #[error("`{0}` is not a finite number")]
    BadNumber(String),
    #[error("`{0}` is not an integer time step")]
    BadStep(String),
    #[error("an interval (intervalStart/intervalEnd) is not a recorded value; need <exact>")]
    Interval,
    #[error("must be > 0, got {0}")]
    NonPositive(f64),
    /// A value no road user has (a broken export's `1e30`, a 35 m "car"): the event folder would
    /// refuse every event of the road user ([`crate::events::LENGTH_RANGE_M`] and the others).
    #[error("{value} {unit} is outside the physical range [{min}, {max}] {unit} an event folder accepts")]
    Unphysical {
        value: f64,
        min: f64,
        max: f64,
        unit: &'static str,
    },
    #[error("<orientation> is more than 45° off the direction the positions move in on {off} of the {moving} steps at 3 m/s or more: degrees instead of radians, or measured from north? CommonRoad orientations are radians, counter-clockwise from the x axis; the importer builds the velocity from them (road user skipped)")]
    HeadingAcrossMotion { off: usize, moving: usize },
    #[error("a rectangle shifted or rotated against the state (<center>/<orientation>) is not supported")]
    OffsetRectangle,
    #[error("scenario id `{id}` was already imported from {first}; event ids would clash (file skipped)")]
    DuplicateScenario { id: String, first: String },
    #[error("time step {step} does not follow step {previous} of the previous state")]
    StepOrder { step: i64, previous: i64 },
    #[error("obstacle id {id} is used again (first at line {first_line}); ids must be unique in a scenario, and events of two road users with one id would clash (file skipped)")]
    DuplicateObstacle { id: String, first_line: u32 },
    #[error("the same file as {first}, which is already read (file skipped)")]
    SameFile { first: String },
    #[error("the same folder as {first}, which is already searched (a link back up the tree, or a second path to it; skipped)")]
    SameFolder { first: String },
    #[error("not UTF-8 (invalid byte 0x{byte:02X}) and no other encoding declared; save the file as UTF-8 or declare encoding=\"ISO-8859-1\" if it is Latin-1")]
    NotUtf8 { byte: u8 },
    #[error(
        "encoding {0:?} is not supported (UTF-8 and ISO-8859-1 are): convert the file to UTF-8"
    )]
    Encoding(String),
    #[error("{0}-compressed: decompress it first (scenario files are read as XML text)")]
    Compressed(&'static str),
}

/// A problem, located: `file:line: <dynamicObstacle id=42> <state> #3 <velocity>: missing <exact>`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}: {context}{problem}")]
pub struct Issue {
    /// The file name as given (path).
    pub file: String,
    /// 1-based line of the element (1 for file-level problems).
    pub line: u32,
    /// Where in the file: the obstacle and the element path, each followed by ": ", or empty.
    pub context: String,
    pub problem: Problem,
}

/// Reads and parses one scenario file. `Err` only when the file as a whole is unusable
/// (unreadable, not XML, not a CommonRoad scenario, no valid `timeStepSize`).
pub fn read_scenario(path: &Path) -> Result<Scenario, Issue> {
    let name = path.display().to_string();
    let file_issue = |line, problem| Issue {
        file: name.clone(),
        line,
        context: String::new(),
        problem,
    };
    let bytes = std::fs::read(path).map_err(|e| file_issue(1, Problem::Io(e.to_string())))?;
    if let Some(format) = compression(&bytes) {
        return Err(file_issue(1, Problem::Compressed(format)));
    }
    let text = decode(bytes).map_err(|(line, problem)| file_issue(line, problem))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| name.clone());
    parse_scenario(&text, &name, &stem)
}

/// The compression format whose magic number `bytes` start with (gzip, zip, xz, bzip2, zstd),
/// if any: such a file is not XML text, and naming the format says what to do.
pub(crate) fn compression(bytes: &[u8]) -> Option<&'static str> {
    const MAGIC: [(&[u8], &str); 5] = [
        (b"\x1F\x8B", "gzip"),
        (b"PK\x03\x04", "zip"),
        (b"\xFD7zXZ\x00", "xz"),
        (b"BZh", "bzip2"),
        (b"\x28\xB5\x2F\xFD", "zstd"),
    ];
    MAGIC
        .iter()
        .find(|(magic, _)| bytes.starts_with(magic))
        .map(|(_, name)| *name)
}

/// The text of an XML file: UTF-8 (a byte-order mark is dropped by the parser), or ISO-8859-1
/// when its declaration says so (every byte is the code point of the same value). Any other
/// declared encoding, or bytes that are not UTF-8 without a declaration, is an error with its line.
fn decode(bytes: Vec<u8>) -> Result<String, (u32, Problem)> {
    // A UTF-16 or UTF-32 file (a "Unicode" save of a text editor) says so by its byte-order
    // mark; its declaration cannot be read byte by byte, so the mark names the encoding.
    const MARKS: [(&[u8], &str); 4] = [
        (b"\xFF\xFE\x00\x00", "UTF-32LE"),
        (b"\x00\x00\xFE\xFF", "UTF-32BE"),
        (b"\xFF\xFE", "UTF-16LE"),
        (b"\xFE\xFF", "UTF-16BE"),
    ];
    if let Some((_, name)) = MARKS.iter().find(|(mark, _)| bytes.starts_with(mark)) {
        return Err((1, Problem::Encoding(format!("{name} (byte-order mark)"))));
    }
    match declared_encoding(&bytes) {
        Some(e) if is_latin1(&e) => return Ok(bytes.iter().map(|&b| char::from(b)).collect()),
        Some(e) if !e.eq_ignore_ascii_case("utf-8") && !e.eq_ignore_ascii_case("us-ascii") => {
            return Err((1, Problem::Encoding(e)))
        }
        _ => {}
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        (
            u32::try_from(line).unwrap_or(u32::MAX),
            Problem::NotUtf8 { byte: bytes[at] },
        )
    })
}

fn is_latin1(encoding: &str) -> bool {
    [
        "iso-8859-1",
        "iso8859-1",
        "iso_8859-1",
        "latin1",
        "latin-1",
        "l1",
    ]
    .iter()
    .any(|name| encoding.eq_ignore_ascii_case(name))
}

/// The `encoding` of an `<?xml ...?>` declaration at the start of the file (after a UTF-8
/// byte-order mark), if there is one.
fn declared_encoding(bytes: &[u8]) -> Option<String> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let rest = bytes.strip_prefix(b"<?xml")?;
    let end = rest.windows(2).position(|w| w == b"?>")?;
    let declaration = std::str::from_utf8(&rest[..end]).ok()?;
    let after = declaration.split("encoding").nth(1)?.trim_start();
    let value = after.strip_prefix('=')?.trim_start();
    let quote = value.chars().next().filter(|c| *c == '"' || *c == '\'')?;
    let value = &value[1..];
    Some(value[..value.find(quote)?].to_string())
}

/// Parses scenario XML `text`; `file` names it in issues, `id` becomes [`Scenario::id`].
pub fn parse_scenario(text: &str, file: &str, id: &str) -> Result<Scenario, Issue> {
    let doc = Document::parse(text).map_err(|e| {
        if matches!(e, roxmltree::Error::DtdDetected) {
            // Well-formed, but a document type declaration is not read (its entities could
            // expand without bound); the parser reports it at 1:1, the line is where it is.
            let at = text.find("<!DOCTYPE").unwrap_or(0);
            let line = 1 + text[..at].matches('\n').count();
            return Issue {
                file: file.to_string(),
                line: u32::try_from(line).unwrap_or(u32::MAX),
                context: String::new(),
                problem: Problem::Doctype,
            };
        }
        // A file cut short is reported at 1:1 too; where it ends is the last line.
        let line = if matches!(
            e,
            roxmltree::Error::UnexpectedEndOfStream | roxmltree::Error::UnclosedRootNode
        ) {
            u32::try_from(1 + text.trim_end().matches('\n').count()).unwrap_or(u32::MAX)
        } else {
            e.pos().row
        };
        Issue {
            file: file.to_string(),
            line,
            context: String::new(),
            problem: Problem::Xml(e.to_string()),
        }
    })?;
    let root = doc.root_element();
    let file_issue = |problem| Issue {
        file: file.to_string(),
        line: line_of(&doc, root),
        context: "<commonRoad>: ".into(),
        problem,
    };
    if root.tag_name().name() != "commonRoad" {
        return Err(Issue {
            context: String::new(),
            ..file_issue(Problem::NotCommonRoad(root.tag_name().name().into()))
        });
    }
    let dt_text = root
        .attribute("timeStepSize")
        .ok_or_else(|| file_issue(Problem::MissingAttribute("timeStepSize")))?;
    let dt = dt_text
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| {
            file_issue(Problem::BadAttribute {
                attribute: "timeStepSize",
                text: dt_text.into(),
            })
        })?;
    let mut scenario = Scenario {
        id: id.to_string(),
        version: root.attribute("commonRoadVersion").unwrap_or("").into(),
        dt,
        origin: (0.0, 0.0),
        tracks: Vec::new(),
        ignored: Vec::new(),
        issues: Vec::new(),
    };
    refuse_duplicate_obstacle_ids(&doc, root, file)?;
    for node in root.children().filter(Node::is_element) {
        let obstacle_id = node.attribute("id").unwrap_or("?").to_string();
        match node.tag_name().name() {
            "dynamicObstacle" => {}
            "obstacle" => match child_text(node, "role") {
                Some("dynamic") => {}
                _ => {
                    scenario.ignored.push((obstacle_id, Ignored::Static));
                    continue;
                }
            },
            "staticObstacle" => {
                scenario.ignored.push((obstacle_id, Ignored::Static));
                continue;
            }
            "environmentObstacle" | "phantomObstacle" => {
                scenario.ignored.push((obstacle_id, Ignored::Environment));
                continue;
            }
            _ => continue,
        }
        let at = Locator {
            doc: &doc,
            file,
            obstacle: format!("<{} id={}> ", node.tag_name().name(), obstacle_id),
        };
        match read_obstacle(node, dt, &at) {
            // Event ids are built from obstacle ids: two road users without one would write
            // clashing events (`x/1-?@0#0` twice), which an event folder drops later.
            Ok(Ok(_)) if node.attribute("id").is_none_or(|id| id.trim().is_empty()) => scenario
                .issues
                .push(at.issue(node, "", Problem::MissingAttribute("id"))),
            Ok(Ok(track)) => match heading_across_motion(&track, dt) {
                Some(problem) => scenario.issues.push(at.issue(node, "", problem)),
                None => scenario.tracks.push(track),
            },
            Ok(Err(why)) => scenario.ignored.push((obstacle_id, why)),
            Err(issue) => scenario.issues.push(issue),
        }
    }
    scenario.origin = local_origin(&scenario.tracks);
    let (ox, oy) = scenario.origin;
    if (ox, oy) != (0.0, 0.0) {
        for s in scenario.tracks.iter_mut().flat_map(|t| t.states.iter_mut()) {
            s.x -= ox;
            s.y -= oy;
        }
    }
    Ok(scenario)
}

/// A road user's orientation must point along the way its positions move (or against it,
/// reversing): the importer builds the velocity from the orientation, so an orientation in
/// degrees or from north gives every frame a velocity across its path, which the event loader
/// cannot see (its heading check compares the heading with that same velocity). Checked as the
/// loader checks headings: more than 45° off on more than half of the consecutive steps that
/// move at [`crate::events::HEADING_CHECK_MIN_SPEED_M_S`] or faster, at least 5 of them.
fn heading_across_motion(track: &Track, dt: f64) -> Option<Problem> {
    let min_speed = f64::from(crate::events::HEADING_CHECK_MIN_SPEED_M_S);
    let (mut moving, mut off) = (0usize, 0usize);
    for w in track.states.windows(2) {
        let (dx, dy) = (w[1].x - w[0].x, w[1].y - w[0].y);
        let distance = dx.hypot(dy);
        if w[1].step - w[0].step != 1 || distance < min_speed * dt {
            continue;
        }
        moving += 1;
        let (sin, cos) = w[0].orientation.sin_cos();
        off += usize::from(crate::events::heading_off((dx * cos + dy * sin) / distance));
    }
    crate::events::heading_mostly_off(off, moving)
        .then_some(Problem::HeadingAcrossMotion { off, moving })
}

/// Largest position coordinate (m) a scenario keeps as it is: event files and every gap computed
/// on the way hold positions as `f32`, which resolves 100 km to 7.8 mm but a UTM northing of
/// 5,400 km only to 0.5 m. The same bound as the loader's note on coarse positions, so an import
/// never writes an event the loader would flag.
pub const FAR_COORDINATE_M: f64 = crate::events::COARSE_POSITION_M as f64;

/// The origin a scenario's positions are taken relative to: `(0, 0)` when every coordinate is
/// within [`FAR_COORDINATE_M`] (the file's own frame, as recorded), else the first state of the
/// first track rounded to whole kilometres (a UTM or other geo-referenced frame: kept as it is,
/// two cars 0.1 m apart would be rounded into overlapping boxes).
pub fn local_origin(tracks: &[Track]) -> (f64, f64) {
    let far = tracks
        .iter()
        .flat_map(|t| &t.states)
        .any(|s| s.x.abs() > FAR_COORDINATE_M || s.y.abs() > FAR_COORDINATE_M);
    match tracks.iter().find_map(|t| t.states.first()) {
        Some(s) if far => (
            (s.x / 1000.0).round() * 1000.0,
            (s.y / 1000.0).round() * 1000.0,
        ),
        _ => (0.0, 0.0),
    }
}

/// Two obstacles of one file with the same id make every event id of their interactions
/// ambiguous (an event folder refuses such ids later, far from their cause): the file is refused
/// with the id and both lines.
fn refuse_duplicate_obstacle_ids(doc: &Document, root: Node, file: &str) -> Result<(), Issue> {
    const OBSTACLES: [&str; 5] = [
        "dynamicObstacle",
        "obstacle",
        "staticObstacle",
        "environmentObstacle",
        "phantomObstacle",
    ];
    let mut first_line: std::collections::HashMap<&str, u32> = std::collections::HashMap::new();
    for node in root.children().filter(Node::is_element) {
        let (true, Some(id)) = (
            OBSTACLES.contains(&node.tag_name().name()),
            node.attribute("id"),
        ) else {
            continue;
        };
        let line = line_of(doc, node);
        if let Some(&first) = first_line.get(id) {
            return Err(Issue {
                file: file.to_string(),
                line,
                context: format!("<{} id={id}>: ", node.tag_name().name()),
                problem: Problem::DuplicateObstacle {
                    id: id.to_string(),
                    first_line: first,
                },
            });
        }
        first_line.insert(id, line);
    }
    Ok(())
}

/// Builds located issues for one obstacle.
struct Locator<'a, 'input> {
    doc: &'a Document<'input>,
    file: &'a str,
    obstacle: String,
}

impl Locator<'_, '_> {
    fn issue(&self, node: Node, path: &str, problem: Problem) -> Issue {
        let sep = if path.is_empty() { "" } else { " " };
        Issue {
            file: self.file.to_string(),
            line: line_of(self.doc, node),
            context: format!("{}{sep}{path}: ", self.obstacle.trim_end()),
            problem,
        }
    }
}

fn line_of(doc: &Document, node: Node) -> u32 {
    doc.text_pos_at(node.range().start).row
}

fn child<'a, 'input>(node: Node<'a, 'input>, name: &str) -> Option<Node<'a, 'input>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

fn child_text<'a>(node: Node<'a, '_>, name: &str) -> Option<&'a str> {
    child(node, name).and_then(|c| c.text()).map(str::trim)
}

/// `Ok(Ok(track))`, `Ok(Err(reason))` for a road user not imported on purpose, `Err` for a
/// malformed one.
fn read_obstacle(node: Node, dt: f64, at: &Locator) -> Result<Result<Track, Ignored>, Issue> {
    let kind = child_text(node, "type").unwrap_or("").to_string();
    if !VEHICLE_TYPES.contains(&kind.as_str()) {
        return Ok(Err(Ignored::Type(kind)));
    }
    let shape =
        child(node, "shape").ok_or_else(|| at.issue(node, "", Problem::Missing("shape")))?;
    let shapes: Vec<Node> = shape.children().filter(Node::is_element).collect();
    let rect = match shapes.as_slice() {
        [r] if r.tag_name().name() == "rectangle" => *r,
        _ => return Ok(Err(Ignored::NotRectangle)),
    };
    let length = dimension(rect, "length", crate::events::LENGTH_RANGE_M, at)?;
    let width = dimension(rect, "width", crate::events::WIDTH_RANGE_M, at)?;
    let shifted = child(rect, "center").is_some_and(|c| {
        ["x", "y"]
            .iter()
            .any(|k| child_text(c, k).and_then(|t| t.parse::<f64>().ok()) != Some(0.0))
    }) || child_text(rect, "orientation")
        .is_some_and(|t| t.parse::<f64>().ok() != Some(0.0));
    if shifted {
        return Err(at.issue(rect, "<shape> <rectangle>", Problem::OffsetRectangle));
    }
    let Some(trajectory) = child(node, "trajectory") else {
        if child(node, "occupancySet").is_some() {
            return Ok(Err(Ignored::NoTrajectory));
        }
        if child(node, "initialState").is_some() {
            return Ok(Err(Ignored::InitialStateOnly));
        }
        return Err(at.issue(node, "", Problem::Missing("trajectory")));
    };
    let initial = child(node, "initialState")
        .ok_or_else(|| at.issue(node, "", Problem::Missing("initialState")))?;
    let mut states = vec![read_state(initial, "<initialState>", at)?];
    for (k, s) in trajectory
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "state")
        .enumerate()
    {
        let path = format!("<state> #{}", k + 1);
        let st = read_state(s, &path, at)?;
        // Files converted from OpenSCENARIO (commonroad-crime's OSC_CutIn-1_2_T-1) repeat the
        // initial state as the trajectory's first state, at the same step: the same recording.
        if k == 0 && states.len() == 1 && states[0] == st {
            continue;
        }
        let previous = states
            .last()
            .map_or(i64::MIN, |p: &(TrackState, bool)| p.0.step);
        if st.0.step <= previous {
            return Err(at.issue(
                s,
                &path,
                Problem::StepOrder {
                    step: st.0.step,
                    previous,
                },
            ));
        }
        states.push(st);
    }
    derive_missing_acceleration(&mut states, dt);
    Ok(Ok(Track {
        id: node.attribute("id").unwrap_or("?").to_string(),
        kind,
        length: length as f32,
        width: width as f32,
        states: states.into_iter().map(|(s, _)| s).collect(),
    }))
}

/// A box dimension (m): positive, and within `range` (inclusive).
fn dimension(
    node: Node,
    name: &'static str,
    range: (f32, f32),
    at: &Locator,
) -> Result<f64, Issue> {
    let path = "<shape> <rectangle>";
    let v = positive(node, name, path, at)?;
    // Compared as the event folder compares it (in f32, where 0.3 is the width's bound), and
    // printed as written (not 0.30000001192092896).
    if (range.0..=range.1).contains(&(v as f32)) {
        Ok(v)
    } else {
        let decimal = |x: f32| x.to_string().parse::<f64>().unwrap_or(f64::from(x));
        let (min, max) = (decimal(range.0), decimal(range.1));
        let c = child(node, name).unwrap_or(node);
        Err(at.issue(
            c,
            &format!("{path} <{name}>"),
            Problem::Unphysical {
                value: v,
                min,
                max,
                unit: "m",
            },
        ))
    }
}

/// `value` of the element `node` when `|value| <= max`, else an [`Problem::Unphysical`] issue.
fn within(
    node: Node,
    value: f64,
    max: f64,
    unit: &'static str,
    path: &str,
    at: &Locator,
) -> Result<f64, Issue> {
    if value.abs() <= max {
        Ok(value)
    } else {
        Err(at.issue(
            node,
            path,
            Problem::Unphysical {
                value,
                min: -max,
                max,
                unit,
            },
        ))
    }
}

fn positive(node: Node, name: &'static str, path: &str, at: &Locator) -> Result<f64, Issue> {
    let c = child(node, name).ok_or_else(|| at.issue(node, path, Problem::Missing(name)))?;
    let text = c.text().unwrap_or("").trim();
    let v = text
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            at.issue(
                c,
                &format!("{path} <{name}>"),
                Problem::BadNumber(text.into()),
            )
        })?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(at.issue(c, &format!("{path} <{name}>"), Problem::NonPositive(v)))
    }
}

/// The `<exact>` text of a value element; `None` when the element is absent.
fn exact<'a, 'i>(
    state: Node<'a, 'i>,
    name: &'static str,
    path: &str,
    at: &Locator,
) -> Result<Option<(Node<'a, 'i>, &'a str)>, Issue> {
    let Some(el) = child(state, name) else {
        return Ok(None);
    };
    match child(el, "exact") {
        Some(e) => Ok(Some((e, e.text().unwrap_or("").trim()))),
        None if child(el, "intervalStart").is_some() => {
            Err(at.issue(el, &format!("{path} <{name}>"), Problem::Interval))
        }
        None => Err(at.issue(el, &format!("{path} <{name}>"), Problem::Missing("exact"))),
    }
}

fn number(node: Node, text: &str, path: &str, at: &Locator) -> Result<f64, Issue> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| at.issue(node, path, Problem::BadNumber(text.into())))
}

/// One state; the flag says whether the acceleration was recorded.
fn read_state(s: Node, path: &str, at: &Locator) -> Result<(TrackState, bool), Issue> {
    let point =
        child(s, "position").ok_or_else(|| at.issue(s, path, Problem::Missing("position")))?;
    let point = child(point, "point").ok_or_else(|| {
        at.issue(
            point,
            &format!("{path} <position>"),
            Problem::Missing("point"),
        )
    })?;
    let coord = |k: &'static str| -> Result<f64, Issue> {
        let p = format!("{path} <position> <point>");
        let c = child(point, k).ok_or_else(|| at.issue(point, &p, Problem::Missing(k)))?;
        let at_k = format!("{p} <{k}>");
        let v = number(c, c.text().unwrap_or("").trim(), &at_k, at)?;
        within(
            c,
            v,
            f64::from(crate::events::MAX_POSITION_M),
            "m",
            &at_k,
            at,
        )
    };
    let (x, y) = (coord("x")?, coord("y")?);
    // The value of a required `<name><exact>`, with its node and its path for issues.
    let required = |name: &'static str| -> Result<(f64, Node, String), Issue> {
        let (node, text) =
            exact(s, name, path, at)?.ok_or_else(|| at.issue(s, path, Problem::Missing(name)))?;
        let element = format!("{path} <{name}> <exact>");
        Ok((number(node, text, &element, at)?, node, element))
    };
    let (orientation, _, _) = required("orientation")?;
    let (speed, speed_node, speed_element) = required("velocity")?;
    let speed = within(
        speed_node,
        speed,
        f64::from(crate::events::MAX_SPEED_M_S),
        "m/s",
        &speed_element,
        at,
    )?;
    let (time_node, time_text) =
        exact(s, "time", path, at)?.ok_or_else(|| at.issue(s, path, Problem::Missing("time")))?;
    let step = time_text.parse::<i64>().map_err(|_| {
        at.issue(
            time_node,
            &format!("{path} <time> <exact>"),
            Problem::BadStep(time_text.into()),
        )
    })?;
    let acc = match exact(s, "acceleration", path, at)? {
        Some((node, text)) => Some(number(
            node,
            text,
            &format!("{path} <acceleration> <exact>"),
            at,
        )?),
        None => None,
    };
    Ok((
        TrackState {
            step,
            x,
            y,
            orientation,
            speed,
            acc: acc.unwrap_or(0.0),
        },
        acc.is_some(),
    ))
}

/// Fills the acceleration of states recorded without one: the time derivative of the speed,
/// central differences between the neighbouring states (one-sided at the ends).
fn derive_missing_acceleration(states: &mut [(TrackState, bool)], dt: f64) {
    let n = states.len();
    for i in 0..n {
        if states[i].1 || n < 2 {
            continue;
        }
        states[i].0.acc = speed_derivative(n, i, dt, |k| (states[k].0.step, states[k].0.speed));
    }
}
