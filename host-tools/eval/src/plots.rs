//! Evaluation figures (plotters), each written as SVG and PNG: ROC curves, precision-recall curves,
//! and risk trajectories of crash events.
//!
//! Text needs a font in both backends (plotters measures labels to lay them out). We embed DejaVu
//! Sans (`fonts/DejaVuSans.ttf`, unmodified, Bitstream Vera licence in `fonts/LICENSE-DejaVu.txt`,
//! which allows redistribution inside software), so figures look the same on every machine and no
//! system font is needed.
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::bundle::{BundleError, ReportBundle, ReportFile};
use super::metrics::WarningCurve;
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

/// Distinct, colour-blind-friendly line colours (Okabe-Ito), reused cyclically.
const COLORS: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(240, 228, 66),
];

fn color(i: usize) -> RGBColor {
    COLORS.get(i % COLORS.len()).copied().unwrap_or(BLACK)
}

/// Renders `figure` as `<stem>.svg` and `<stem>.png` in memory, so a caller can write them
/// through a temporary file (nothing half-drawn ever lands at the destination).
fn both_formats(
    stem: &str,
    size: (u32, u32),
    figure: &Figure<'_>,
) -> Result<[ReportFile; 2], PlotError> {
    register_font();
    let svg_name = format!("{stem}.svg");
    let png_name = format!("{stem}.png");
    let drawing = |name: &str| {
        let name = name.to_owned();
        move |source: Box<dyn std::error::Error + Send + Sync>| PlotError::Draw { name, source }
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| drawing(&svg_name)(e.into()))?;
    }
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| drawing(&png_name)(e.into()))?;
    }
    let png = encode_png(&rgb, size).map_err(|source| PlotError::Png {
        name: png_name.clone(),
        source,
    })?;
    Ok([
        ReportFile {
            name: svg_name,
            bytes: svg.into_bytes(),
        },
        ReportFile {
            name: png_name,
            bytes: png,
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

/// What one figure shows, independent of the backend.
pub enum Figure<'a> {
    Roc(&'a [(String, WarningCurve)]),
    Pr(&'a [(String, WarningCurve)]),
    Trajectories(&'a [TrajectoryPanel]),
}

impl Figure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        root.fill(&WHITE)?;
        match self {
            Figure::Roc(curves) => draw_roc(root, curves),
            Figure::Pr(curves) => draw_pr(root, curves),
            Figure::Trajectories(panels) => draw_trajectories(root, panels),
        }
    }
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// The ROC and PR charts' frame: `[0, 1] x [0, y_max]`, captioned, with both axes described.
type UnitChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn unit_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    caption: &str,
    y_max: f64,
    (x_desc, y_desc): (&str, &str),
) -> Result<UnitChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = ChartBuilder::on(root)
        .caption(caption, (FONT, 26))
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

/// A method's line: its index among all methods (its colour), its points and its legend label.
type MethodLine = (usize, Vec<(f64, f64)>, String);

/// One line per method, coloured by its index among all methods, and the legend at `position`.
fn draw_method_lines<'a, DB: DrawingBackend + 'a>(
    chart: &mut UnitChart<'a, DB>,
    lines: Vec<MethodLine>,
    position: SeriesLabelPosition,
) -> DrawResult<DB> {
    for (i, points, label) in lines {
        let c = color(i);
        chart
            .draw_series(LineSeries::new(points, c.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(position)
        .label_font((FONT, 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

fn draw_roc<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    curves: &[(String, WarningCurve)],
) -> DrawResult<DB> {
    let mut chart = unit_chart(
        root,
        "ROC of the first-threshold warning",
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
    let lines = curves
        .iter()
        .enumerate()
        .filter_map(|(i, (name, curve))| {
            let label = match curve.a_roc(90) {
                Some(a) => format!("{name} (A^ROC_90 = {a:.1} %)"),
                None => name.clone(),
            };
            Some((i, curve.roc_curve()?, label))
        })
        .collect();
    draw_method_lines(&mut chart, lines, SeriesLabelPosition::LowerRight)
}

fn draw_pr<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    curves: &[(String, WarningCurve)],
) -> DrawResult<DB> {
    let mut chart = unit_chart(
        root,
        "Precision-recall of the first-threshold warning",
        1.02,
        ("recall (conflicts warned)", "precision"),
    )?;
    let lines = curves
        .iter()
        .enumerate()
        .filter_map(|(i, (name, curve))| {
            let points = curve.pr_points();
            let label = match curve.p_prc(90) {
                Some(p) => format!("{name} (P^PRC_90 = {p:.1} %)"),
                None => name.clone(),
            };
            (!points.is_empty()).then_some((i, points, label))
        })
        .collect();
    draw_method_lines(&mut chart, lines, SeriesLabelPosition::LowerLeft)
}

fn draw_trajectories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[TrajectoryPanel],
) -> DrawResult<DB> {
    let root = root.titled(
        "Risk trajectories of crash events (each method as its percentile over all frames)",
        (FONT, 24),
    )?;
    let areas = root.split_evenly((1, panels.len().max(1)));
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
        for (i, (name, line)) in panel.lines.iter().enumerate() {
            let c = color(i);
            chart
                .draw_series(LineSeries::new(line.iter().copied(), c.stroke_width(2)))?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    Ok(())
}

/// `roc.{svg,png}` and `pr.{svg,png}`, rendered in memory.
pub fn curve_figures(curves: &[(String, WarningCurve)]) -> Result<Vec<ReportFile>, PlotError> {
    let mut files = Vec::from(both_formats("roc", SIZE, &Figure::Roc(curves))?);
    files.extend(both_formats("pr", SIZE, &Figure::Pr(curves))?);
    Ok(files)
}

/// `trajectories.{svg,png}` (one panel per event), rendered in memory.
pub fn trajectory_figures(panels: &[TrajectoryPanel]) -> Result<Vec<ReportFile>, PlotError> {
    Ok(Vec::from(both_formats(
        "trajectories",
        TRAJECTORY_SIZE,
        &Figure::Trajectories(panels),
    )?))
}

/// Writes `roc.{svg,png}` and `pr.{svg,png}` into `dir`; returns the paths written.
pub fn plot_curves(
    dir: &Path,
    curves: &[(String, WarningCurve)],
) -> Result<Vec<PathBuf>, PlotError> {
    let files = curve_figures(curves)?;
    Ok(ReportBundle { files }.write_to(dir)?)
}

/// Writes `trajectories.{svg,png}` into `dir` (one panel per event); returns the paths written.
pub fn plot_trajectories(
    dir: &Path,
    panels: &[TrajectoryPanel],
) -> Result<Vec<PathBuf>, PlotError> {
    let files = trajectory_figures(panels)?;
    Ok(ReportBundle { files }.write_to(dir)?)
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
        let written = plot_curves(dir.path(), &[("M".into(), curve)]).unwrap();
        assert_eq!(written.len(), 4);
        let svg = std::fs::read_to_string(dir.path().join("roc.svg")).unwrap();
        assert!(svg.contains("A^ROC_90"), "legend text is drawn");
        let png = std::fs::read(dir.path().join("pr.png")).unwrap();
        assert_eq!(&png[..4], b"\x89PNG");
    }
}
