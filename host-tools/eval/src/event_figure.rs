//! A picture of one event (`riskctl plot`, the demo's event figures): a bird's-eye view of both
//! road users' paths with their boxes at the first warning and at the endpoint, and below it one
//! strip per method with its risk over time, its threshold and its first warning.
//!
//! Every score is computed here through scorer-core exactly as `riskctl evaluate` computes it
//! ([`observe_frames`], [`Method`]); the first warning follows the evaluation protocol's rule
//! ([`first_alert`]: the first frame with R >= threshold up to the endpoint, inclusive).
use plotters::coord::Shift;
use plotters::prelude::*;

use super::palette::{MethodStyle, Palette};
use super::plots::{
    caption_height, captioned, draw_legend_strip, draw_styled, render, DrawResult, Picture,
};
use super::plots::{ImageFormat, PlotError};
use super::protocol::{first_alert, Baseline, NO_CONFLICT_RISK};
use super::scoring::{observe_frames, Method, ObservedSequence};
use riskscore_data::events::{Event, EventKind};
use scorer_core::VehicleState;

/// One method's risk over an event.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodTrace {
    pub name: String,
    /// `(time (s), R)`; NaN where the method sees no conflict or has no score (drawn as a gap).
    pub risk: Vec<(f64, f64)>,
    /// The threshold drawn and warned at, if any.
    pub threshold: Option<f32>,
    /// Time of the first warning at `threshold` ([`first_alert`]).
    pub first_warning: Option<f64>,
}

/// Everything one event picture shows.
#[derive(Clone, Debug, PartialEq)]
pub struct EventPicture {
    pub event: Event,
    pub methods: Vec<MethodTrace>,
    /// Which models scored it, when that needs saying (printed under the caption).
    pub note: Option<String>,
}

/// Width of an event picture in pixels, and the heights of its parts.
const WIDTH: u32 = 1100;
const MAP_HEIGHT: u32 = 520;
const STRIP_HEIGHT: u32 = 150;
/// Room for the map's y labels: world coordinates can have seven digits and a decimal.
const MAP_Y_LABELS: u32 = 96;
/// Left edge of the map's key, clear of the y labels.
const KEY_X: i32 = MAP_Y_LABELS as i32 + 28;
/// Legend entries per row at this width (see `plots::draw_legend_strip`).
const LEGEND_PER_ROW: usize = (WIDTH as usize - 32) / 190;

impl EventPicture {
    /// Scores `event` with every method (through scorer-core) and finds each first warning at the
    /// method's entry of `thresholds` (same order as `methods`; missing entries mean none).
    pub fn score(event: Event, methods: &[Method<'_>], thresholds: &[Option<f32>]) -> Self {
        let observed = observe_frames(&event.frames);
        let traces = methods
            .iter()
            .enumerate()
            .map(|(i, method)| {
                let sequence = ObservedSequence {
                    event_id: event.id.clone(),
                    kind: event.kind,
                    endpoint: event.t_impact,
                    frames: observed.clone(),
                }
                .score(|f| method.scorer.score(&f.observation));
                let threshold = thresholds.get(i).copied().flatten();
                MethodTrace {
                    name: method.name.clone(),
                    risk: sequence
                        .frames
                        .iter()
                        .map(|f| (f.time, drawn_risk(f.score)))
                        .collect(),
                    threshold,
                    first_warning: threshold.and_then(|t| first_alert(&sequence, t)),
                }
            })
            .collect();
        EventPicture {
            event,
            methods: traces,
            note: None,
        }
    }

    /// The size of the picture in pixels (it grows with the number of methods).
    pub fn size(&self) -> (u32, u32) {
        let strips = self.methods.len().max(1) as u32;
        (
            WIDTH,
            caption_height(&self.subtitle())
                + MAP_HEIGHT
                + strips * STRIP_HEIGHT
                + legend_height(self.methods.len()),
        )
    }

    /// The first warning drawn on the map: the first method (in the given order) that warns.
    pub fn map_warning(&self) -> Option<(&str, f64)> {
        self.methods
            .iter()
            .find_map(|m| Some((m.name.as_str(), m.first_warning?)))
    }

    /// The lines under the caption: the endpoint, how risk and warnings are computed, the note.
    fn subtitle(&self) -> String {
        let endpoint = match self.event.t_impact {
            Some(t) if self.event.kind == EventKind::Crash => format!("impact at t = {t:.2} s"),
            Some(t) => format!("safety-critical moment at t = {t:.2} s"),
            None => "no endpoint (safe): boxes filled at the last frame".to_owned(),
        };
        let mut text = format!(
            "{endpoint}; time in s\nrisk R as scored by riskctl evaluate (scorer-core); first \
             warning = first frame with R >= threshold up to the endpoint"
        );
        if let Some(note) = &self.note {
            text.push('\n');
            text.push_str(note);
        }
        text
    }

    /// The picture as an SVG or PNG file's bytes.
    pub fn render(&self, format: ImageFormat) -> Result<Vec<u8>, PlotError> {
        render(&self.event.id, format, self.size(), self)
    }
}

/// Height of the legend strip for `n` methods (every entry shown).
fn legend_height(n: usize) -> u32 {
    22 + 22 * n.div_ceil(LEGEND_PER_ROW).max(1) as u32
}

/// A score as drawn: no conflict and no score are gaps.
fn drawn_risk(r: f32) -> f64 {
    if r.is_nan() || r <= NO_CONFLICT_RISK {
        f64::NAN
    } else {
        f64::from(r)
    }
}

/// Road-user colours on the map (not method colours).
const EGO: RGBColor = RGBColor(40, 40, 40);
const PARTNER: RGBColor = RGBColor(200, 40, 60);

impl Picture for EventPicture {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let ev = &self.event;
        let body = captioned(
            root,
            &format!("event {} ({})", ev.id, ev.kind.as_str()),
            &self.subtitle(),
        )?;
        let (map, rest) = body.split_vertically(MAP_HEIGHT);
        let (strips, legend) = rest.split_vertically(
            rest.dim_in_pixel()
                .1
                .saturating_sub(legend_height(self.methods.len())),
        );
        self.draw_map(&map)?;
        let mut palette = Palette::for_methods(self.methods.iter().map(|m| m.name.as_str()));
        let (t0, t1) = time_range(ev);
        let areas = strips.split_evenly((self.methods.len().max(1), 1));
        for (trace, area) in self.methods.iter().zip(&areas) {
            draw_strip(
                area,
                trace,
                palette.style(&trace.name),
                (t0, t1),
                ev.t_impact,
            )?;
        }
        let entries: Vec<(String, MethodStyle)> = self
            .methods
            .iter()
            .map(|m| (m.name.clone(), palette.style(&m.name)))
            .collect();
        draw_legend_strip(&legend, &entries)
    }
}

impl EventPicture {
    /// The bird's-eye view: both paths, equal scale on both axes, boxes at the first warning
    /// (outlined) and at the endpoint (filled).
    fn draw_map<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let ev = &self.event;
        let (x_range, y_range) = map_ranges(ev, area.dim_in_pixel());
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(MAP_Y_LABELS)
            .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)?;
        chart
            .configure_mesh()
            .x_desc("x (m, world frame)")
            .y_desc("y (m)")
            .label_style(("sans-serif", 14))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for (colour, pick) in [(EGO, true), (PARTNER, false)] {
            let path: Vec<(f64, f64)> = ev
                .frames
                .iter()
                .map(|f| {
                    let s = if pick { &f.ego } else { &f.partner };
                    (f64::from(s.x), f64::from(s.y))
                })
                .collect();
            chart.draw_series(LineSeries::new(
                path.iter().copied(),
                colour.stroke_width(2),
            ))?;
            if let Some(&start) = path.first() {
                chart.draw_series(std::iter::once(Circle::new(start, 4, colour.filled())))?;
            }
        }
        let end_time = ev.t_impact.or_else(|| ev.frames.last().map(|f| f.time));
        let mut labels: Vec<(f64, String)> = Vec::new();
        if let Some((name, t)) = self.map_warning() {
            labels.push((
                t,
                format!("outlined: first warning ({name}) at t = {t:.2} s"),
            ));
            if let Some(f) = frame_at(ev, t) {
                for (s, colour) in [(&f.ego, EGO), (&f.partner, PARTNER)] {
                    chart.draw_series(std::iter::once(Polygon::new(
                        box_corners(s).to_vec(),
                        colour.mix(0.05),
                    )))?;
                    let mut outline = box_corners(s).to_vec();
                    outline.push(outline[0]);
                    chart.draw_series(LineSeries::new(outline, colour.stroke_width(2)))?;
                }
            }
        }
        if let Some(t) = end_time {
            labels.push((t, format!("filled: endpoint at t = {t:.2} s")));
            if let Some(f) = frame_at(ev, t) {
                for (s, colour) in [(&f.ego, EGO), (&f.partner, PARTNER)] {
                    chart.draw_series(std::iter::once(Polygon::new(
                        box_corners(s).to_vec(),
                        colour.mix(0.55).filled(),
                    )))?;
                }
            }
        }
        // A key in the chart's top-left corner of the pixel area, clear of the axes.
        let text = ("sans-serif", 14).into_text_style(area);
        let mut y = 16;
        for (colour, what) in [
            (EGO, "ego path (dot: first frame)"),
            (PARTNER, "partner path"),
        ] {
            area.draw(&PathElement::new(
                [(KEY_X, y + 7), (KEY_X + 24, y + 7)],
                colour.stroke_width(3),
            ))?;
            area.draw_text(what, &text, (KEY_X + 32, y))?;
            y += 18;
        }
        for (_, what) in labels {
            area.draw_text(&what, &text, (KEY_X, y))?;
            y += 18;
        }
        Ok(())
    }
}

/// One method's strip: its risk over time, its threshold (dashed grey), its first warning
/// (a vertical line) and the endpoint (a black vertical line).
fn draw_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    trace: &MethodTrace,
    style: MethodStyle,
    (t0, t1): (f64, f64),
    endpoint: Option<f64>,
) -> DrawResult<DB> {
    let (lo, hi) = risk_range(trace);
    let warning = match (trace.threshold, trace.first_warning) {
        (Some(t), Some(w)) => format!("threshold {t}: first warning at {w:.2} s"),
        (Some(t), None) => format!("threshold {t}: no warning"),
        (None, _) => "no threshold given".to_owned(),
    };
    let mut chart = ChartBuilder::on(area)
        .margin_left(12)
        .margin_right(12)
        .margin_top(6)
        .caption(format!("{}: {warning}", trace.name), ("sans-serif", 15))
        .x_label_area_size(26)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, lo..hi)?;
    chart
        .configure_mesh()
        .y_desc(axis_name(&trace.name))
        .label_style(("sans-serif", 12))
        .light_line_style(RGBColor(240, 240, 240))
        .y_labels(4)
        .draw()?;
    if let Some(t) = trace.threshold {
        let t = f64::from(t);
        chart.draw_series(DashedLineSeries::new(
            [(t0, t), (t1, t)],
            6,
            4,
            RGBColor(120, 120, 120).stroke_width(1),
        ))?;
    }
    if let Some(e) = endpoint {
        chart.draw_series(LineSeries::new([(e, lo), (e, hi)], BLACK.stroke_width(1)))?;
    }
    // Values beyond the axis (a time baseline's far-away moments) are drawn at its edge: plotters
    // maps points to integer pixels and cannot place 10^7 s.
    let shown: Vec<(f64, f64)> = trace
        .risk
        .iter()
        .map(|&(t, r)| (t, if r.is_nan() { r } else { r.clamp(lo, hi) }))
        .collect();
    draw_styled(&mut chart, &shown, style, None)?;
    if let Some(w) = trace.first_warning {
        let colour = super::plots::rgb(style);
        chart.draw_series(LineSeries::new([(w, lo), (w, hi)], colour.stroke_width(2)))?;
        let at = trace
            .risk
            .iter()
            .find(|p| p.0 >= w)
            .map_or(hi, |p| p.1.clamp(lo, hi));
        chart.draw_series(std::iter::once(TriangleMarker::new(
            (w, at),
            7,
            colour.filled(),
        )))?;
    }
    Ok(())
}

/// The y-axis name of a method: the baselines' risk is a negated time or an intensity.
fn axis_name(name: &str) -> String {
    match Baseline::named(name) {
        Some(b) if b.surrogate().larger_is_riskier() => format!("R = {} (m/s)", b.name()),
        Some(b) => format!("R = -{} (s)", b.name()),
        None => "R".to_owned(),
    }
}

/// The time axis: the event's frames and its endpoint, at least 1 s wide (a shorter span is
/// centred in a 1 s window).
fn time_range(ev: &Event) -> (f64, f64) {
    let times = ev.frames.iter().map(|f| f.time).chain(ev.t_impact);
    let (t0, t1) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
        (lo.min(t), hi.max(t))
    });
    if !(t0.is_finite() && t1.is_finite()) {
        return (0.0, 1.0);
    }
    if t1 - t0 < 1.0 {
        let mid = 0.5 * (t0 + t1);
        (mid - 0.5, mid + 0.5)
    } else {
        (t0, t1)
    }
}

/// A strip's y range: the finite risks and the threshold, with a little room. Time-type
/// baselines are cut at -10 s, so one far-away moment does not flatten the rest.
fn risk_range(trace: &MethodTrace) -> (f64, f64) {
    let floor = match Baseline::named(&trace.name) {
        Some(b) if !b.surrogate().larger_is_riskier() => -10.0,
        _ => f64::NEG_INFINITY,
    };
    let values = trace
        .risk
        .iter()
        .map(|p| p.1)
        .chain(trace.threshold.map(f64::from))
        .filter(|v| v.is_finite())
        .map(|v| v.max(floor));
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(0.05);
    (lo - pad, hi + pad)
}

/// The map's x and y ranges: every box corner, with a margin, at one scale on both axes.
fn map_ranges(ev: &Event, (width, height): (u32, u32)) -> ((f64, f64), (f64, f64)) {
    let corners = ev.frames.iter().flat_map(|f| {
        box_corners(&f.ego)
            .into_iter()
            .chain(box_corners(&f.partner))
    });
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in corners {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    let (x0, x1, y0, y1) = (x0 - 3.0, x1 + 3.0, y0 - 3.0, y1 + 3.0);
    // Metres per pixel of the plotting area (less the axis label areas), equal on both axes.
    let (w, h) = (
        f64::from(width.saturating_sub(MAP_Y_LABELS + 36).max(1)),
        f64::from(height.saturating_sub(64).max(1)),
    );
    let scale = ((x1 - x0) / w).max((y1 - y0) / h);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    (
        (cx - scale * w / 2.0, cx + scale * w / 2.0),
        (cy - scale * h / 2.0, cy + scale * h / 2.0),
    )
}

/// The frame nearest to time `t`.
fn frame_at(ev: &Event, t: f64) -> Option<&riskscore_data::events::Frame> {
    ev.frames
        .iter()
        .min_by(|a, b| (a.time - t).abs().total_cmp(&(b.time - t).abs()))
}

/// The four corners of a road user's box (centre, unit heading, length, width).
fn box_corners(s: &VehicleState) -> [(f64, f64); 4] {
    let (x, y) = (f64::from(s.x), f64::from(s.y));
    let (mut hx, mut hy) = (f64::from(s.hx), f64::from(s.hy));
    let norm = hx.hypot(hy);
    if norm > 0.0 {
        hx /= norm;
        hy /= norm;
    } else {
        (hx, hy) = (1.0, 0.0);
    }
    let (l, w) = (f64::from(s.length) / 2.0, f64::from(s.width) / 2.0);
    let (nx, ny) = (-hy, hx);
    [
        (x + hx * l + nx * w, y + hy * l + ny * w),
        (x + hx * l - nx * w, y + hy * l - ny * w),
        (x - hx * l - nx * w, y - hy * l - ny * w),
        (x - hx * l + nx * w, y - hy * l + ny * w),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_is_its_length_along_the_heading() {
        let s = VehicleState {
            x: 10.0,
            y: 5.0,
            hx: 0.0,
            hy: 1.0,
            length: 4.0,
            width: 2.0,
            ..VehicleState::default()
        };
        let c = box_corners(&s);
        // Heading north: the front corners are 2 m north of the centre, 1 m either side.
        assert_eq!(c[0], (9.0, 7.0));
        assert_eq!(c[1], (11.0, 7.0));
        assert_eq!(c[2], (11.0, 3.0));
    }

    #[test]
    fn the_time_axis_holds_every_frame_and_the_endpoint() {
        let frame = |time| riskscore_data::events::Frame {
            time,
            ..Default::default()
        };
        let mut ev = Event {
            id: "e".into(),
            kind: EventKind::Crash,
            t_start: 1.8,
            t_end: 2.7,
            t_impact: Some(2.75),
            dims: Default::default(),
            frames: (18..=27).map(|k| frame(f64::from(k) / 10.0)).collect(),
        };
        let (a, b) = time_range(&ev);
        assert!(
            a <= 1.8 && b >= 2.75 && (b - a - 1.0).abs() < 1e-9,
            "{a}..{b}"
        );
        ev.t_impact = None;
        ev.frames = (0..=40).map(|k| frame(f64::from(k) / 10.0)).collect();
        assert_eq!(time_range(&ev), (0.0, 4.0));
    }

    #[test]
    fn no_conflict_is_a_gap_and_the_range_ignores_it() {
        assert!(drawn_risk(NO_CONFLICT_RISK).is_nan());
        assert!(drawn_risk(f32::NAN).is_nan());
        let trace = MethodTrace {
            name: "TTC2D".into(),
            risk: vec![(0.0, f64::NAN), (0.1, -3.0), (0.2, -400.0)],
            threshold: Some(-1.5),
            first_warning: None,
        };
        let (lo, hi) = risk_range(&trace);
        assert!((-11.0..-10.0).contains(&lo), "far times are cut: {lo}");
        assert!(hi > -1.5, "the threshold is in view: {hi}");
    }
}
