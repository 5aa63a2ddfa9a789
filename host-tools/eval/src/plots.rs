//! Evaluation figures (plotters), each written as SVG and PNG: ROC curves, precision-recall curves,
//! and risk trajectories of conflict events (crash or near-crash sequences, up to their endpoint).
//!
//! Text needs a font in both backends (plotters measures labels to lay them out). We embed DejaVu
//! Sans (`fonts/DejaVuSans.ttf`, unmodified, Bitstream Vera licence in `fonts/LICENSE-DejaVu.txt`,
//! which allows redistribution inside software), so figures look the same on every machine and no
//! system font is needed.
use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::bundle::{BundleError, ReportFile};
use super::metrics::WarningCurve;
use super::palette::{LineStyle, MethodStyle, Palette};
use super::report::fixed;
pub use super::trajectory::{
    alert_window_scores, default_trajectory_events, percentile, trajectory_panels,
    trajectory_panels_ranked, TrajectoryPanel,
};

const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The embedded file is a valid TrueType font; a failure would only show as missing text.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES);
    });
}

/// A figure could not be drawn, encoded or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// plotters failed while drawing the figure `name`.
    #[error("{name}: drawing failed")]
    Draw {
        name: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("{name}: encoding the PNG failed")]
    Png {
        name: String,
        #[source]
        source: png::EncodingError,
    },
    #[error(transparent)]
    Write(#[from] BundleError),
}

/// Size of every figure in pixels (SVG user units).
const SIZE: (u32, u32) = (900, 700);
const TRAJECTORY_SIZE: (u32, u32) = (1500, 520);

/// The plotters colour of a palette style.
pub(crate) fn rgb(style: MethodStyle) -> RGBColor {
    let (r, g, b) = style.rgb;
    RGBColor(r, g, b)
}

/// Draws `points` in `style` on `chart`, broken into separate runs wherever a y value is NaN
/// (a gap, e.g. where a surrogate is infinite), and labels the method in the chart's legend.
pub(crate) fn draw_styled<'a, DB: DrawingBackend + 'a>(
    chart: &mut UnitChart<'a, DB>,
    points: &[(f64, f64)],
    style: MethodStyle,
    label: Option<String>,
) -> DrawResult<DB> {
    let colour = rgb(style);
    let stroke = colour.stroke_width(style.width);
    let mut labelled = label.is_none();
    for run in points
        .split(|p| !p.1.is_finite() || !p.0.is_finite())
        .filter(|r| !r.is_empty())
    {
        if let [point] = run {
            // A lone frame between gaps would draw nothing as a line.
            chart.draw_series(std::iter::once(Circle::new(
                *point,
                style.width + 1,
                colour.filled(),
            )))?;
            continue;
        }
        let anno = match style.line {
            LineStyle::Solid => chart.draw_series(LineSeries::new(run.iter().copied(), stroke))?,
            LineStyle::Dashed => {
                chart.draw_series(DashedLineSeries::new(run.iter().copied(), 8, 5, stroke))?
            }
        };
        if !labelled {
            labelled = true;
            let gap = if style.line == LineStyle::Dashed {
                5
            } else {
                0
            };
            anno.label(label.clone().unwrap_or_default())
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new([(0, 0), (8, 0)], stroke)
                        + PathElement::new([(8 + gap, 0), (22, 0)], stroke)
                });
        }
    }
    Ok(())
}

/// Something drawable on any plotters backend (so one figure renders as SVG and as PNG).
pub(crate) trait Picture {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB>;
}

/// The image formats a figure is written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Svg,
    Png,
}

impl ImageFormat {
    /// The format a file name asks for by its extension (`.svg` or `.png`, any case).
    pub fn of_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "svg" => Some(Self::Svg),
            "png" => Some(Self::Png),
            _ => None,
        }
    }
}

/// Renders `figure` in `format` in memory; `name` names the figure in errors.
pub(crate) fn render(
    name: &str,
    format: ImageFormat,
    size: (u32, u32),
    figure: &impl Picture,
) -> Result<Vec<u8>, PlotError> {
    register_font();
    let drawing = |source: Box<dyn std::error::Error + Send + Sync>| PlotError::Draw {
        name: name.to_owned(),
        source,
    };
    match format {
        ImageFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                root.fill(&WHITE)
                    .and_then(|()| figure.draw(&root))
                    .and_then(|()| root.present())
                    .map_err(|e| drawing(e.into()))?;
            }
            Ok(svg.into_bytes())
        }
        ImageFormat::Png => {
            let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
                root.fill(&WHITE)
                    .and_then(|()| figure.draw(&root))
                    .and_then(|()| root.present())
                    .map_err(|e| drawing(e.into()))?;
            }
            encode_png(&rgb, size).map_err(|source| PlotError::Png {
                name: name.to_owned(),
                source,
            })
        }
    }
}

/// Renders `figure` as `<stem>.svg` and `<stem>.png` in memory, so a caller can write them
/// through a temporary file (nothing half-drawn ever lands at the destination).
pub(crate) fn both_formats(
    stem: &str,
    size: (u32, u32),
    figure: &impl Picture,
) -> Result<[ReportFile; 2], PlotError> {
    let svg_name = format!("{stem}.svg");
    let png_name = format!("{stem}.png");
    Ok([
        ReportFile {
            bytes: render(&svg_name, ImageFormat::Svg, size, figure)?,
            name: svg_name,
        },
        ReportFile {
            bytes: render(&png_name, ImageFormat::Png, size, figure)?,
            name: png_name,
        },
    ])
}

/// An 8-bit RGB buffer as a PNG file.
fn encode_png(rgb: &[u8], (width, height): (u32, u32)) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(out)
}

/// What one figure shows, independent of the backend. `scores` says which scores are drawn (it
/// is printed under the caption, so a figure cannot be mistaken for a table it does not match).
pub(crate) enum Figure<'a> {
    Roc {
        curves: &'a [(String, WarningCurve)],
        scores: &'a str,
    },
    Pr {
        curves: &'a [(String, WarningCurve)],
        scores: &'a str,
    },
    Trajectories {
        panels: &'a [TrajectoryPanel],
        scores: &'a str,
    },
}

impl Picture for Figure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        match self {
            Figure::Roc { curves, scores } => draw_roc(root, curves, scores),
            Figure::Pr { curves, scores } => draw_pr(root, curves, scores),
            Figure::Trajectories { panels, scores } => draw_trajectories(root, panels, scores),
        }
    }
}

pub(crate) type DrawResult<DB> =
    Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A chart with `f64` axes (ROC, PR, trajectories, event pictures).
pub(crate) type UnitChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Height in pixels of a caption with `note` under it (one line per `\n`-separated line).
pub(crate) fn caption_height(note: &str) -> u32 {
    46 + 18 * note.lines().count().max(1) as u32
}

/// Splits off a caption line and smaller note lines under it; returns the area below.
pub(crate) fn captioned<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    caption: &str,
    note: &str,
) -> Result<DrawingArea<DB, Shift>, DrawingAreaErrorKind<DB::ErrorType>> {
    let (head, body) = root.split_vertically(caption_height(note));
    head.draw_text(caption, &(FONT, 24).into_text_style(&head), (16, 8))?;
    let style = (FONT, 15)
        .into_text_style(&head)
        .color(&RGBColor(80, 80, 80));
    for (i, line) in note.lines().enumerate() {
        head.draw_text(line, &style, (16, 40 + 18 * i as i32))?;
    }
    Ok(body)
}

/// The ROC and PR charts' frame: `[0, 1] x [0, y_max]`, both axes described.
fn unit_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    y_max: f64,
    (x_desc, y_desc): (&str, &str),
) -> Result<UnitChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = ChartBuilder::on(root)
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..1f64, 0f64..y_max)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style((FONT, 16))
        .light_line_style(WHITE)
        .draw()?;
    Ok(chart)
}

/// A method's line: its name (its style), its points and its legend label.
type MethodLine = (String, Vec<(f64, f64)>, String);

/// One line per method in the method's own style, and the legend at `position`.
fn draw_method_lines<'a, DB: DrawingBackend + 'a>(
    chart: &mut UnitChart<'a, DB>,
    palette: &mut Palette,
    lines: Vec<MethodLine>,
    position: SeriesLabelPosition,
) -> DrawResult<DB> {
    for (name, points, label) in lines {
        draw_styled(chart, &points, palette.style(&name), Some(label))?;
    }
    chart
        .configure_series_labels()
        .position(position)
        .label_font((FONT, 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

/// The palette of a figure over `names`: extras numbered in this order in every figure of a run.
fn palette_of<'a>(names: impl IntoIterator<Item = &'a String>) -> Palette {
    Palette::for_methods(names.into_iter().map(String::as_str))
}

fn draw_roc<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    curves: &[(String, WarningCurve)],
    scores: &str,
) -> DrawResult<DB> {
    let body = captioned(root, "ROC of the first-threshold warning", scores)?;
    let mut chart = unit_chart(
        &body,
        1.0,
        (
            "false positive rate (safe sequences warned)",
            "true positive rate (conflicts warned)",
        ),
    )?;
    // Chance line and the recall levels of A^ROC_90 / A^ROC_80.
    let grey = RGBColor(170, 170, 170);
    chart.draw_series(LineSeries::new(
        [(0.0, 0.0), (1.0, 1.0)],
        grey.stroke_width(1),
    ))?;
    for level in [0.8, 0.9] {
        chart.draw_series(LineSeries::new(
            [(0.0, level), (1.0, level)],
            grey.mix(0.6).stroke_width(1),
        ))?;
    }
    let mut palette = palette_of(curves.iter().map(|(n, _)| n));
    let lines = curves
        .iter()
        .filter_map(|(name, curve)| {
            let label = match curve.a_roc(90) {
                Some(a) => format!("{name} (A^ROC_90 = {} %)", fixed(a, 1)),
                None => name.clone(),
            };
            Some((name.clone(), curve.roc_curve()?, label))
        })
        .collect();
    draw_method_lines(
        &mut chart,
        &mut palette,
        lines,
        SeriesLabelPosition::LowerRight,
    )
}

fn draw_pr<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    curves: &[(String, WarningCurve)],
    scores: &str,
) -> DrawResult<DB> {
    let body = captioned(
        root,
        "Precision-recall of the first-threshold warning",
        scores,
    )?;
    let mut chart = unit_chart(&body, 1.02, ("recall (conflicts warned)", "precision"))?;
    let mut palette = palette_of(curves.iter().map(|(n, _)| n));
    let lines = curves
        .iter()
        .filter_map(|(name, curve)| {
            let points = curve.pr_points();
            let label = match curve.p_prc(90) {
                Some(p) => format!("{name} (P^PRC_90 = {} %)", fixed(p, 1)),
                None => name.clone(),
            };
            (!points.is_empty()).then_some((name.clone(), points, label))
        })
        .collect();
    draw_method_lines(
        &mut chart,
        &mut palette,
        lines,
        SeriesLabelPosition::LowerLeft,
    )
}

/// A row of legend entries (line sample and name) across `area`, outside every chart.
pub(crate) fn draw_legend_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, MethodStyle)],
) -> DrawResult<DB> {
    let (width, height) = area.dim_in_pixel();
    let per_row = ((width as usize).saturating_sub(32) / 190).max(1);
    let text = (FONT, 15).into_text_style(area);
    for (i, (name, style)) in entries.iter().enumerate() {
        let x = 24 + (i % per_row) as i32 * 190;
        let y = 12 + (i / per_row) as i32 * 22;
        if y as u32 >= height {
            break;
        }
        let stroke = rgb(*style).stroke_width(style.width);
        let gap = if style.line == LineStyle::Dashed {
            6
        } else {
            0
        };
        area.draw(&PathElement::new([(x, y + 8), (x + 12, y + 8)], stroke))?;
        area.draw(&PathElement::new(
            [(x + 12 + gap, y + 8), (x + 32, y + 8)],
            stroke,
        ))?;
        area.draw_text(name, &text, (x + 40, y))?;
    }
    Ok(())
}

/// The trajectory figure's title. Its panels are conflict sequences: by default the first crash
/// sequences, else the crash or near-crash sequences asked for (`--trajectory-event`).
const TRAJECTORY_TITLE: &str =
    "Risk trajectories of crash or near-crash events (each method as its percentile over all frames)";

fn draw_trajectories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[TrajectoryPanel],
    scores: &str,
) -> DrawResult<DB> {
    let body = captioned(root, TRAJECTORY_TITLE, scores)?;
    let (charts, legend) = body.split_vertically(body.dim_in_pixel().1.saturating_sub(56));
    let names: Vec<&String> = panels
        .iter()
        .flat_map(|p| p.lines.iter().map(|(n, _)| n))
        .collect();
    let mut palette = palette_of(names.iter().copied());
    let mut seen: Vec<(String, MethodStyle)> = Vec::new();
    for name in names {
        if !seen.iter().any(|(n, _)| n == name) {
            seen.push((name.clone(), palette.style(name)));
        }
    }
    let areas = charts.split_evenly((1, panels.len().max(1)));
    for (panel, area) in panels.iter().zip(&areas) {
        let (lo, hi) = panel
            .lines
            .iter()
            .flat_map(|(_, l)| l.iter().map(|p| p.0))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
                (lo.min(t), hi.max(t))
            });
        let (lo, hi) = if lo < hi { (lo, hi) } else { (-4.5, 0.5) };
        let mut chart = ChartBuilder::on(area)
            .caption(format!("event {}", panel.event_id), (FONT, 18))
            .margin(10)
            .x_label_area_size(42)
            .y_label_area_size(48)
            .build_cartesian_2d(lo..hi, 0f64..1.02f64)?;
        chart
            .configure_mesh()
            .x_desc("time relative to impact (s)")
            .y_desc("risk percentile")
            .label_style((FONT, 14))
            .light_line_style(WHITE)
            .draw()?;
        chart.draw_series(LineSeries::new(
            [(0.0, 0.0), (0.0, 1.02)],
            RGBColor(120, 120, 120).stroke_width(1),
        ))?;
        for (name, line) in &panel.lines {
            draw_styled(&mut chart, line, palette.style(name), None)?;
        }
    }
    draw_legend_strip(&legend, &seen)
}

/// `roc.{svg,png}` and `pr.{svg,png}`, rendered in memory; `scores` says which scores the curves
/// come from (printed under each caption).
pub fn curve_figures(
    curves: &[(String, WarningCurve)],
    scores: &str,
) -> Result<Vec<ReportFile>, PlotError> {
    let mut files = Vec::from(both_formats("roc", SIZE, &Figure::Roc { curves, scores })?);
    files.extend(both_formats("pr", SIZE, &Figure::Pr { curves, scores })?);
    Ok(files)
}

/// `trajectories.{svg,png}` (one panel per event), rendered in memory.
pub fn trajectory_figures(
    panels: &[TrajectoryPanel],
    scores: &str,
) -> Result<Vec<ReportFile>, PlotError> {
    Ok(Vec::from(both_formats(
        "trajectories",
        TRAJECTORY_SIZE,
        &Figure::Trajectories { panels, scores },
    )?))
}

/// File names of every figure [`curve_figures`] and [`trajectory_figures`] produce.
pub const FIGURE_FILES: [&str; 6] = [
    "roc.svg",
    "roc.png",
    "pr.svg",
    "pr.png",
    "trajectories.svg",
    "trajectories.png",
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bundle::ReportBundle;
    use crate::protocol::test_sequence as seq;
    use crate::protocol::EventKind;

    #[test]
    fn figures_render_to_svg_and_png() {
        let dir = tempfile::tempdir().unwrap();
        let seqs = vec![
            seq("c", EventKind::Crash, Some(2.0), &[1.0, 2.0, 3.0]),
            seq("s", EventKind::Safe, None, &[0.0, 2.5]),
        ];
        let curve = crate::warning_curve(&crate::protocol::alert_profiles(&seqs).unwrap());
        let files = curve_figures(&[("M".into(), curve)], "the test's scores").unwrap();
        let written = ReportBundle { files }.write_into(dir.path()).unwrap();
        assert_eq!(written.len(), 4);
        let svg = std::fs::read_to_string(dir.path().join("roc.svg")).unwrap();
        assert!(svg.contains("A^ROC_90"), "legend text is drawn");
        assert!(svg.contains("the test&apos;s scores") || svg.contains("the test's scores"));
        let png = std::fs::read(dir.path().join("pr.png")).unwrap();
        assert_eq!(&png[..4], b"\x89PNG");
    }

    /// A method's stroke colour in an SVG, as plotters writes it.
    fn stroke_of(name: &str) -> String {
        let (r, g, b) = Palette::new().style(name).rgb;
        format!("stroke=\"#{r:02X}{g:02X}{b:02X}\"")
    }

    #[test]
    fn a_method_keeps_its_colour_whatever_its_row() {
        let seqs = vec![
            seq("c", EventKind::Crash, Some(2.0), &[1.0, 2.0, 3.0]),
            seq("s", EventKind::Safe, None, &[0.0, 2.5]),
        ];
        let curve = crate::warning_curve(&crate::protocol::alert_profiles(&seqs).unwrap());
        let svg_of = |names: &[&str]| {
            let curves: Vec<(String, WarningCurve)> = names
                .iter()
                .map(|n| ((*n).to_owned(), curve.clone()))
                .collect();
            let files = curve_figures(&curves, "test").unwrap();
            String::from_utf8(files[0].bytes.clone()).unwrap()
        };
        let alone = svg_of(&["DRL"]);
        let second = svg_of(&["TAdv", "DRL"]);
        for svg in [&alone, &second] {
            assert!(
                svg.contains(&stroke_of("DRL")),
                "DRL is drawn in its colour"
            );
        }
        assert!(second.contains(&stroke_of("TAdv")));
        // Two identical extras both show: different colours.
        let twins = svg_of(&["drl-a", "drl-b"]);
        assert!(twins.contains(&stroke_of("drl-a")));
        let mut palette = Palette::for_methods(["drl-a"]);
        let (r, g, b) = palette.style("drl-b").rgb;
        assert!(twins.contains(&format!("stroke=\"#{r:02X}{g:02X}{b:02X}\"")));
    }
}
