//! Inline SVG charts drawn with plotters' SVG backend.
//!
//! plotters is built without its font features: its SVG backend writes text
//! as plain `<text>` elements (font-family `sans-serif`) that the browser
//! renders, and only estimates text extents for layout — no system fonts are
//! read at build or run time.  Legends are written in HTML beside the chart
//! (see `legend`) so long channel lists wrap instead of overlapping the data.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use super::html::escape;

/// Okabe–Ito colour-blind-safe palette (yellow left out: too pale on white).
/// A series' index picks the colour; past the palette the series is dashed.
pub const PALETTE: [(u8, u8, u8); 7] = [
    (0, 114, 178),   // blue
    (213, 94, 0),    // vermillion
    (0, 158, 115),   // bluish green
    (204, 121, 167), // reddish purple
    (230, 159, 0),   // orange
    (86, 180, 233),  // sky blue
    (0, 0, 0),       // black
];

pub fn colour(index: usize) -> RGBColor {
    let (r, g, b) = PALETTE[index % PALETTE.len()];
    RGBColor(r, g, b)
}

pub fn css_colour(index: usize) -> String {
    let (r, g, b) = PALETTE[index % PALETTE.len()];
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mark {
    Line,
    Dashed,
    FilledCircle,
    HollowCircle,
    Cross,
    Triangle,
    /// Line with a filled circle at each point (short profiles).
    LinePoints,
}

#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub colour: usize,
    pub mark: Mark,
}

impl Series {
    pub fn new(
        label: impl Into<String>,
        points: Vec<(f64, f64)>,
        colour: usize,
        mark: Mark,
    ) -> Self {
        // Past the palette, lines become dashed so no two series look alike.
        let mark = if mark == Mark::Line && colour >= PALETTE.len() {
            Mark::Dashed
        } else {
            mark
        };
        Series {
            label: label.into(),
            points,
            colour,
            mark,
        }
    }
}

/// A reference line across the chart (thresholds, identified frequencies).
#[derive(Debug, Clone)]
pub struct RefLine {
    pub at: f64,
    pub horizontal: bool,
    pub colour: usize,
}

/// A text label at a data point (channel names on a mode shape).
#[derive(Debug, Clone)]
pub struct Annotation {
    pub x: f64,
    pub y: f64,
    pub text: String,
    pub colour: usize,
}

#[derive(Debug, Clone)]
pub struct Chart {
    pub width: u32,
    pub height: u32,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
    pub ref_lines: Vec<RefLine>,
    pub annotations: Vec<Annotation>,
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    /// Share of the data range added on each side of an automatic linear
    /// axis (x: none for lines, 3 % for scatter charts; y: 5 %).
    pub x_pad: Option<f64>,
    pub y_pad: f64,
    /// Width of the y label area, px (default: from the tick labels); set
    /// equal on charts stacked on one x axis so their plot areas line up.
    pub y_label_area: Option<u32>,
}

impl Chart {
    pub fn new(width: u32, height: u32, x_label: &str, y_label: &str) -> Self {
        Chart {
            width,
            height,
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            series: Vec::new(),
            ref_lines: Vec::new(),
            annotations: Vec::new(),
            x_range: None,
            y_range: None,
            x_pad: None,
            y_pad: 0.05,
            y_label_area: None,
        }
    }
}

/// Range of finite values (positive only when `positive`), padded when
/// degenerate so the axis has a width.
fn data_range(values: impl Iterator<Item = f64>, positive: bool) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!positive || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return None;
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(lo.abs()).max(1e-300) {
        if positive {
            return Some((lo / 2.0, hi * 2.0));
        }
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        return Some((lo - pad, hi + pad));
    }
    Some((lo, hi))
}

/// Renders the chart as an inline `<svg>` element (no XML declaration, no
/// namespace URL — inline SVG in HTML needs neither).  The `<svg>` carries
/// the plotting area in pixels (`data-plot-area="x0 y0 x1 y1"`), so a reader
/// (the browser test) can relate drawn coordinates to the axes.
pub fn render(chart: &Chart) -> Result<String, String> {
    if !chart
        .series
        .iter()
        .any(|s| s.points.iter().any(|p| p.0.is_finite() && p.1.is_finite()))
    {
        return Err("no finite data to plot".into());
    }
    let x_range = match chart.x_range {
        Some(r) => Some(r),
        None => data_range(
            chart
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.0)),
            chart.log_x,
        ),
    }
    .ok_or("no finite data to plot")?;
    // Markers at the data extremes would sit on the frame: pad linear x axes
    // of scatter charts.
    let scatter = chart.series.iter().any(|s| {
        matches!(
            s.mark,
            Mark::FilledCircle | Mark::HollowCircle | Mark::Cross | Mark::Triangle
        )
    });
    let x_pad = chart.x_pad.unwrap_or(if scatter { 0.03 } else { 0.0 });
    let x_range = if !chart.log_x && chart.x_range.is_none() {
        let pad = x_pad * (x_range.1 - x_range.0);
        (x_range.0 - pad, x_range.1 + pad)
    } else {
        x_range
    };
    let y_range = match chart.y_range {
        Some(r) => Some(r),
        None => data_range(
            chart
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1))
                .chain(
                    chart
                        .ref_lines
                        .iter()
                        .filter(|l| l.horizontal)
                        .map(|l| l.at),
                ),
            chart.log_y,
        )
        .map(|(lo, hi)| {
            if chart.log_y {
                let pad = (hi / lo).powf(chart.y_pad);
                (lo / pad, hi * pad)
            } else {
                let pad = chart.y_pad * (hi - lo);
                (lo - pad, hi + pad)
            }
        }),
    }
    .ok_or("no finite data to plot")?;
    let (x, y) = (x_range.0..x_range.1, y_range.0..y_range.1);
    let svg = match (chart.log_x, chart.log_y) {
        (false, false) => draw(chart, x, y)?,
        (true, false) => draw(chart, x.log_scale(), y)?,
        (false, true) => draw(chart, x, y.log_scale())?,
        (true, true) => draw(chart, x.log_scale(), y.log_scale())?,
    };
    Ok(clean_svg(&svg))
}

/// Width of the y label area: the widest tick label (estimated from the
/// range ends and middle, 7 px a character at 12 px) plus the axis title,
/// so neither is clipped.
fn y_label_area(chart: &Chart, y: (f64, f64)) -> u32 {
    let widest = if chart.log_y {
        [y.0, y.1]
            .iter()
            .map(|v| log_tick(*v).len())
            .max()
            .unwrap_or(4)
    } else {
        let step = (y.1 - y.0) / 6.0;
        [y.0, y.1, 0.5 * (y.0 + y.1), y.0 + step, y.1 - step]
            .iter()
            .map(|v| tick(nice(*v, step)).chars().count())
            .max()
            .unwrap_or(4)
    };
    (26 + 7 * widest as u32).max(48)
}

/// `v` rounded to the precision of a tick step (what plotters labels).
fn nice(v: f64, step: f64) -> f64 {
    if !(step.is_finite() && step > 0.0) {
        return v;
    }
    let unit = 10f64.powf(step.log10().floor());
    (v / unit).round() * unit
}

fn draw<XS, YS>(chart: &Chart, x_spec: XS, y_spec: YS) -> Result<String, String>
where
    XS: AsRangedCoord<Value = f64>,
    XS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YS: AsRangedCoord<Value = f64>,
    YS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut buf = String::new();
    let own_series;
    let area;
    {
        let root =
            SVGBackend::with_string(&mut buf, (chart.width, chart.height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let y_spec: YS::CoordDescType = y_spec.into();
        let y_area = chart
            .y_label_area
            .unwrap_or_else(|| y_label_area(chart, (y_spec.range().start, y_spec.range().end)));
        let mut ctx = ChartBuilder::on(&root)
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(y_area)
            .build_cartesian_2d(x_spec, y_spec)
            .map_err(|e| e.to_string())?;
        // Tick labels: short decimals on linear axes, powers of ten on log
        // axes (plotters' own float formatting writes 9.999999999e-6).
        // A tick at zero computed as a rounding residue (3.5e-18 on an
        // axis of centimetres) is written 0.
        let (xs, ys) = (ctx.x_range(), ctx.y_range());
        let (x_span, y_span) = ((xs.end - xs.start).abs(), (ys.end - ys.start).abs());
        let y_tick = |v: &f64| tick(if v.abs() < 1e-9 * y_span { 0.0 } else { *v });
        let x_tick = |v: &f64| tick(if v.abs() < 1e-9 * x_span { 0.0 } else { *v });
        let mut mesh = ctx.configure_mesh();
        mesh.x_desc(chart.x_label.as_str())
            .y_desc(chart.y_label.as_str())
            .x_labels(8)
            .y_labels(6)
            .light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(215, 215, 215))
            .axis_desc_style(("sans-serif", 13))
            .label_style(("sans-serif", 12));
        if chart.log_y {
            mesh.y_label_formatter(&|v| log_tick(*v));
        } else {
            mesh.y_label_formatter(&y_tick);
        }
        if !chart.log_x {
            mesh.x_label_formatter(&x_tick);
        }
        mesh.draw().map_err(|e| e.to_string())?;
        let x_lim = ctx.x_range();
        let y_lim = ctx.y_range();
        let (px, py) = ctx.plotting_area().get_pixel_range();
        area = (px.start, py.start, px.end, py.end);
        // Data → pixel, in floating point (plotters rounds to whole pixels):
        // the mapping of the axis ends, interpolated (in ln for a log axis).
        let (a, b) = (
            ctx.backend_coord(&(x_lim.start, y_lim.start)),
            ctx.backend_coord(&(x_lim.end, y_lim.end)),
        );
        let axis = |v: f64, lo: f64, hi: f64, p0: i32, p1: i32, log: bool| -> f64 {
            let f = if log {
                (v.ln() - lo.ln()) / (hi.ln() - lo.ln())
            } else {
                (v - lo) / (hi - lo)
            };
            f64::from(p0) + f * f64::from(p1 - p0)
        };
        let to_pixel = |x: f64, y: f64| {
            (
                axis(x, x_lim.start, x_lim.end, a.0, b.0, chart.log_x),
                axis(y, y_lim.start, y_lim.end, a.1, b.1, chart.log_y),
            )
        };
        let inside = |x: f64, y: f64| {
            x.is_finite()
                && y.is_finite()
                && x >= x_lim.start
                && x <= x_lim.end
                && y >= y_lim.start
                && y <= y_lim.end
        };
        own_series = line_elements(chart, &to_pixel, &inside);
        for l in &chart.ref_lines {
            let style = ShapeStyle::from(&colour(l.colour)).stroke_width(1);
            let pts = if l.horizontal {
                if l.at < y_lim.start || l.at > y_lim.end {
                    continue;
                }
                vec![(x_lim.start, l.at), (x_lim.end, l.at)]
            } else {
                if l.at < x_lim.start || l.at > x_lim.end {
                    continue;
                }
                vec![(l.at, y_lim.start), (l.at, y_lim.end)]
            };
            ctx.draw_series(DashedLineSeries::new(pts, 6, 4, style))
                .map_err(|e| e.to_string())?;
        }
        for s in &chart.series {
            let c = colour(s.colour);
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| {
                    x.is_finite()
                        && y.is_finite()
                        && *x >= x_lim.start
                        && *x <= x_lim.end
                        && *y >= y_lim.start
                        && *y <= y_lim.end
                })
                .collect();
            let drawn = match s.mark {
                // Lines are written below as one polyline each (`line_elements`).
                Mark::Line | Mark::Dashed => Ok(()),
                Mark::LinePoints => {
                    match ctx.draw_series(LineSeries::new(
                        pts.clone(),
                        ShapeStyle::from(&c).stroke_width(2),
                    )) {
                        Ok(_) => ctx
                            .draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))
                            .map(|_| ()),
                        Err(e) => Err(e),
                    }
                }
                Mark::FilledCircle => ctx
                    .draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))
                    .map(|_| ()),
                Mark::HollowCircle => ctx
                    .draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.stroke_width(1))))
                    .map(|_| ()),
                Mark::Cross => ctx
                    .draw_series(pts.iter().map(|p| Cross::new(*p, 2, c.stroke_width(1))))
                    .map(|_| ()),
                Mark::Triangle => ctx
                    .draw_series(
                        pts.iter()
                            .map(|p| TriangleMarker::new(*p, 3, c.stroke_width(1))),
                    )
                    .map(|_| ()),
            };
            drawn.map_err(|e| e.to_string())?;
        }
        for a in &chart.annotations {
            if !inside(a.x, a.y) {
                continue;
            }
            // Right of the point, or left of it in the right part of the
            // plot (about 6 px a character), so the label stays inside.
            let (px0, px1) = (f64::from(area.0), f64::from(area.2));
            let right_part = to_pixel(a.x, a.y).0 > px0 + 0.6 * (px1 - px0);
            let dx = if right_part {
                -(6 * a.text.chars().count() as i32 + 4)
            } else {
                4
            };
            let style = ("sans-serif", 11).into_font().color(&colour(a.colour));
            ctx.draw_series(std::iter::once(
                EmptyElement::at((a.x, a.y)) + Text::new(a.text.clone(), (dx, -13), style),
            ))
            .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    let end = buf.rfind("</svg>").unwrap_or(buf.len());
    buf.insert_str(end, &own_series);
    let tag = format!(
        "<svg data-plot-area=\"{} {} {} {}\" ",
        area.0, area.1, area.2, area.3
    );
    Ok(buf.replacen("<svg ", &tag, 1))
}

/// The `Line` and `Dashed` series as SVG polylines in pixel coordinates
/// with one decimal (plotters would round to whole pixels and write a
/// dashed line as one element per dash).  A run of points is broken where a
/// point is off the axes or not finite, so no segment joins across a gap.
fn line_elements(
    chart: &Chart,
    to_pixel: &dyn Fn(f64, f64) -> (f64, f64),
    inside: &dyn Fn(f64, f64) -> bool,
) -> String {
    let mut out = String::new();
    for s in &chart.series {
        let dash = match s.mark {
            Mark::Line => "",
            Mark::Dashed => " stroke-dasharray=\"5 3\"",
            _ => continue,
        };
        let mut run: Vec<String> = Vec::new();
        let mut flush = |run: &mut Vec<String>| {
            if run.len() >= 2 {
                out.push_str(&format!(
                    "<polyline class=\"series\" fill=\"none\" stroke=\"{}\" stroke-width=\"1\"{dash} points=\"{}\"/>\n",
                    css_colour(s.colour),
                    run.join(" ")
                ));
            }
            run.clear();
        };
        for &(x, y) in &s.points {
            if inside(x, y) {
                let (px, py) = to_pixel(x, y);
                run.push(format!("{px:.1},{py:.1}"));
            } else {
                flush(&mut run);
            }
        }
        flush(&mut run);
    }
    out
}

/// Tick label: short, scientific for very small or large magnitudes.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

/// Tick label of a log axis: "1e-5" at a power of ten, else one significant
/// digit ("3e-5"), or the linear label between 1e-3 and 1e5.
fn log_tick(v: f64) -> String {
    if !(v > 0.0) {
        return tick(v);
    }
    let e = v.log10();
    if (e - e.round()).abs() < 1e-6 {
        let e = e.round() as i32;
        return if (-3..5).contains(&e) {
            tick(10f64.powi(e))
        } else {
            format!("1e{e}")
        };
    }
    if (1e-3..1e5).contains(&v) {
        tick(v)
    } else {
        format!("{v:.0e}")
    }
}

/// Drops the XML prolog and namespace URL and makes the chart scale with
/// its container.
fn clean_svg(svg: &str) -> String {
    let start = svg.find("<svg").unwrap_or(0);
    svg[start..]
        .replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1)
        .replacen("<svg ", "<svg class=\"plot\" role=\"img\" ", 1)
}

/// Shades a band on a rendered chart: a translucent polygon through
/// (x, low) and (x, high) in the colour `colour`, with `title` as its
/// tooltip, mapped onto the chart's plot area (`data-plot-area` of the
/// rendered SVG).  The chart's ranges must be explicit, so the mapping is
/// exact: linear, or in ln on a log x axis.  Values outside the y range are
/// clamped to it.
pub fn shade_band(
    svg: &str,
    chart: &Chart,
    band: &[(f64, f64, f64)],
    colour: usize,
    title: &str,
) -> String {
    let (Some((x0, x1)), Some((y0, y1))) = (chart.x_range, chart.y_range) else {
        return svg.to_string();
    };
    let area: Option<Vec<f64>> = svg
        .split("data-plot-area=\"")
        .nth(1)
        .and_then(|r| r.split('"').next())
        .map(|a| a.split(' ').filter_map(|v| v.parse().ok()).collect());
    let Some([px0, py0, px1, py1]) = area.as_deref().and_then(|a| <[f64; 4]>::try_from(a).ok())
    else {
        return svg.to_string();
    };
    let fx = |x: f64| {
        if chart.log_x {
            (x.ln() - x0.ln()) / (x1.ln() - x0.ln())
        } else {
            (x - x0) / (x1 - x0)
        }
    };
    let px = |x: f64| px0 + fx(x) * (px1 - px0);
    let py = |y: f64| py1 - (y.clamp(y0, y1) - y0) / (y1 - y0) * (py1 - py0);
    let mut points: Vec<String> = band
        .iter()
        .map(|&(x, _, hi)| format!("{:.1},{:.1}", px(x), py(hi)))
        .collect();
    points.extend(
        band.iter()
            .rev()
            .map(|&(x, lo, _)| format!("{:.1},{:.1}", px(x), py(lo))),
    );
    let polygon = format!(
        "<polygon points=\"{}\" fill=\"{}\" fill-opacity=\"0.18\" stroke=\"none\"><title>{}</title></polygon>",
        points.join(" "),
        css_colour(colour),
        escape(title)
    );
    match svg.rfind("</svg>") {
        Some(at) => format!("{}{polygon}{}", &svg[..at], &svg[at..]),
        None => svg.to_string(),
    }
}

/// HTML legend: a swatch (colour and mark) and the label of every series.
pub fn legend(series: &[Series]) -> String {
    let mut s = String::from("<ul class=\"legend\">");
    for x in series {
        let glyph = match x.mark {
            Mark::Line | Mark::LinePoints => "━",
            Mark::Dashed => "╍",
            Mark::FilledCircle => "●",
            Mark::HollowCircle => "○",
            Mark::Cross => "✕",
            Mark::Triangle => "△",
        };
        s.push_str(&format!(
            "<li><span class=\"swatch\" style=\"color:{}\">{glyph}</span> {}</li>",
            css_colour(x.colour),
            escape(&x.label)
        ));
    }
    s.push_str("</ul>");
    s
}

/// Min–max decimation for display: splits the trace into `max_points / 2`
/// buckets and keeps each bucket's minimum and maximum in time order, so
/// peaks survive.  Plot-only: every reported number comes from the tables.
pub fn decimate_min_max(points: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    let mut d = MinMaxDecimator::new(points.len(), max_points);
    for &p in points {
        d.push(p);
    }
    d.finish()
}

/// [`decimate_min_max`] fed a point at a time, the number of points known
/// up front: a trace read from a big table in batches is decimated without
/// being held (the result is the same).
pub struct MinMaxDecimator {
    len: usize,
    buckets: usize,
    /// Few enough points to keep them all.
    keep_all: bool,
    out: Vec<(f64, f64)>,
    /// Index of the next point, the current bucket and where it ends.
    next: usize,
    bucket: usize,
    end: usize,
    /// The current bucket's first minimum and first maximum (index, point).
    extremes: Option<((usize, (f64, f64)), (usize, (f64, f64)))>,
}

impl MinMaxDecimator {
    pub fn new(len: usize, max_points: usize) -> Self {
        let max_points = max_points.max(2);
        let buckets = max_points / 2;
        MinMaxDecimator {
            len,
            buckets,
            keep_all: len <= max_points,
            out: Vec::new(),
            next: 0,
            bucket: 0,
            end: len / buckets.max(1),
            extremes: None,
        }
    }

    pub fn push(&mut self, p: (f64, f64)) {
        let i = self.next;
        self.next += 1;
        if self.keep_all {
            self.out.push(p);
            return;
        }
        while i >= self.end && self.bucket < self.buckets {
            self.flush();
            self.bucket += 1;
            self.end = ((self.bucket + 1) * self.len / self.buckets).min(self.len);
        }
        match &mut self.extremes {
            None => self.extremes = Some(((i, p), (i, p))),
            Some((min, max)) => {
                if p.1 < min.1 .1 {
                    *min = (i, p);
                }
                if p.1 > max.1 .1 {
                    *max = (i, p);
                }
            }
        }
    }

    fn flush(&mut self) {
        if let Some((min, max)) = self.extremes.take() {
            let (first, second) = if min.0 <= max.0 {
                (min, max)
            } else {
                (max, min)
            };
            self.out.push(first.1);
            if second.0 != first.0 {
                self.out.push(second.1);
            }
        }
    }

    /// The decimated trace.
    pub fn finish(mut self) -> Vec<(f64, f64)> {
        self.flush();
        self.out
    }
}

/// Longest drawn segment of a decimated curve, as a share of the data range
/// in either axis (unless one sample step of the data is longer).
pub const CURVE_MAX_STEP: f64 = 0.025;

/// Decimation of a parametric x–y curve (a force–drift loop) for display,
/// in time order: at most `max_points` points, in axes normalised by the
/// data ranges.
///
/// - A step rule: no drawn segment spans more than [`CURVE_MAX_STEP`] of
///   either axis, unless a single step of the data does (a point is kept
///   before the path leaves the box of that half-width round the last kept
///   point); the step grows only when the budget cannot hold it.
/// - Ramer–Douglas–Peucker within the remaining budget (the tolerance
///   bisected to it): points far from the chord of their neighbours — the
///   reversals, where the curvature is — are kept first.
/// - The first and last points and those of extreme x and y are always
///   kept, so the loop's peak drift and force are drawn exactly.
///
/// Never min–max per bin: that assumes x increases with the sample index and
/// turns a loop into chords.
pub fn decimate_curve(points: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    let max_points = max_points.max(8);
    let finite: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    if finite.len() <= max_points {
        return finite;
    }
    let range = |f: fn(&(f64, f64)) -> f64| {
        let (lo, hi) = finite
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        if hi > lo {
            hi - lo
        } else {
            1.0
        }
    };
    let (sx, sy) = (range(|p| p.0), range(|p| p.1));
    let norm: Vec<(f64, f64)> = finite.iter().map(|p| (p.0 / sx, p.1 / sy)).collect();
    let arg = |f: &dyn Fn(&(f64, f64), &(f64, f64)) -> bool| -> usize {
        (0..norm.len()).fold(0, |best, i| if f(&norm[i], &norm[best]) { i } else { best })
    };
    let mut forced = vec![
        0,
        norm.len() - 1,
        arg(&|a, b| a.0 < b.0),
        arg(&|a, b| a.0 > b.0),
        arg(&|a, b| a.1 < b.1),
        arg(&|a, b| a.1 > b.1),
    ];
    forced.sort_unstable();
    forced.dedup();
    let mut base = vec![false; norm.len()];
    for &i in &forced {
        base[i] = true;
    }
    let count = |k: &[bool]| k.iter().filter(|x| **x).count();
    // The step rule, widened until it fits the budget.
    let mut step = CURVE_MAX_STEP;
    let mut stepped = step_points(&norm, &base, step);
    while count(&stepped) > max_points && step < 1.0 {
        step *= 1.25;
        stepped = step_points(&norm, &base, step);
    }
    // Ramer–Douglas–Peucker splits the chord (a, b) at its farthest point whatever the
    // tolerance, so the split tree is the same for every tolerance: build it once, recording
    // for each split point the smallest chord distance on its path from the root. RDP at
    // tolerance `tol` keeps exactly the points whose recorded distance exceeds `tol` (a split
    // happens when its own distance, and those of every split above it, exceed `tol`).
    let mut split_at = vec![f64::NEG_INFINITY; norm.len()];
    let mut stack: Vec<(usize, usize, f64)> = forced
        .windows(2)
        .map(|w| (w[0], w[1], f64::INFINITY))
        .collect();
    while let Some((a, b, above)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (p, q) = (norm[a], norm[b]);
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let len = (dx * dx + dy * dy).sqrt();
        let (mut worst, mut at) = (-1.0, a);
        for (i, r) in norm.iter().enumerate().take(b).skip(a + 1) {
            let d = if len > 0.0 {
                ((r.0 - p.0) * dy - (r.1 - p.1) * dx).abs() / len
            } else {
                ((r.0 - p.0).powi(2) + (r.1 - p.1).powi(2)).sqrt()
            };
            if d > worst {
                worst = d;
                at = i;
            }
        }
        // The bisection's tolerances are all positive: a chord at distance 0 never splits.
        if worst > 0.0 {
            let reach = worst.min(above);
            split_at[at] = reach;
            stack.push((a, at, reach));
            stack.push((at, b, reach));
        }
    }
    let keep_with = |tol: f64| -> Vec<bool> {
        stepped
            .iter()
            .zip(&split_at)
            .map(|(s, d)| *s || *d > tol)
            .collect()
    };
    // Bisect the tolerance (normalised units) to the largest count ≤ budget.
    let (mut lo, mut hi) = (0.0f64, 2.0f64);
    let mut best = keep_with(hi);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        let k = keep_with(mid);
        if count(&k) <= max_points {
            hi = mid;
            best = k;
        } else {
            lo = mid;
        }
    }
    finite
        .iter()
        .zip(&best)
        .filter(|(_, k)| **k)
        .map(|(p, _)| *p)
        .collect()
}

/// `kept` plus the points the step rule keeps: walking in order, the point
/// before the one that leaves the box of half-width `step` (either axis)
/// round the last kept point, and that point too when its own step from
/// there is longer than `step`.
fn step_points(norm: &[(f64, f64)], kept: &[bool], step: f64) -> Vec<bool> {
    let mut keep = kept.to_vec();
    let far = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() > step || (a.1 - b.1).abs() > step;
    let mut last = 0;
    for i in 1..norm.len() {
        if far(norm[i], norm[last]) && i - 1 > last {
            keep[i - 1] = true;
            last = i - 1;
        }
        if keep[i] || far(norm[i], norm[last]) {
            keep[i] = true;
            last = i;
        }
    }
    keep
}
