//! Mode shapes (modes/modes.parquet): one chart per mode on the sensor layout,
//! and the shape components under the channel names of the table's
//! `quaketwin.output_channels` metadata.
//!
//! Where every output channel has a level (channels/channels.parquet), a mode is drawn
//! as a storey profile: level up, component across, one line per direction
//! (X, Y, …) through the levels; several sensors of one direction on a level
//! (a torsion pair) are drawn as separate lines, so components in opposite
//! senses show side by side.  Otherwise the components are drawn against the
//! channel's position in the list, each labelled with its name.

use std::collections::BTreeMap;

use super::{channel_info, figure_with, Loaded};
use crate::report::format_number;
use crate::report::html::{direction_text, escape, note, table, Cell};
use crate::report::plot::{self, Annotation, Chart, Mark, RefLine, Series};
use crate::report::table::{Column, Table};
use crate::vocab::tables::modes;

/// Most channels whose names are written beside the points.
const MAX_LABELS: usize = 16;

/// The output channel ids of modes/modes.parquet (metadata), if stated.
pub(super) fn output_channels(t: &Table) -> Vec<String> {
    t.metadata
        .get("quaketwin.output_channels")
        .and_then(|s| serde_json::from_str(s).ok())
        .unwrap_or_default()
}

fn shapes(t: &Table) -> Option<&[Option<Vec<f64>>]> {
    list_column(t, modes::SHAPE_RE.name)
}

fn list_column<'a>(t: &'a Table, name: &str) -> Option<&'a [Option<Vec<f64>>]> {
    match t.columns.get(name) {
        Some(Column::NumberList(v)) => Some(v),
        _ => None,
    }
}

/// Below this modal phase collinearity a shape is markedly complex: its
/// real part (what is drawn) misrepresents it, and the caption says so.
const COMPLEX_MPC: f64 = 0.9;

/// The shape charts and the components table.
pub(super) fn mode_shapes(t: &Table, channels: &Loaded) -> String {
    let mut body = String::new();
    let Some(shapes) = shapes(t) else {
        return note("The identified modes carry no shapes: no mode shapes to draw.");
    };
    let mut names = output_channels(t);
    let width = shapes.iter().flatten().map(Vec::len).max().unwrap_or(0);
    if names.len() != width {
        body.push_str(&note(&format!(
            "{} output channel name(s) recorded for {width} shape component(s): components numbered instead.",
            names.len()
        )));
        names = (1..=width).map(|i| format!("#{i}")).collect();
    }
    let info = channel_info(channels);
    // Level and direction of every component, when channels/channels.parquet has them.
    let layout: Option<Vec<(i32, String)>> = names
        .iter()
        .map(|n| {
            let (dir, level) = info.get(n)?;
            Some((level.as_ref()?.parse().ok()?, dir.clone()?))
        })
        .collect();
    body.push_str(&note(&match &layout {
        Some(_) => "Mode shapes on the storey layout: level up, real part of the component across (largest component 1), one line \
                    per direction; channel names beside the points. Levels and directions from the channel table."
            .to_string(),
        None => "Mode shapes: real part of each component (largest 1) against the channel's position; channel levels are not all \
                 known (channel table), so no storey profile is drawn."
            .to_string(),
    }));
    body.push_str("<div class=\"multiples\">");
    let num = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    for (r, shape) in shapes.iter().enumerate() {
        let mode = t
            .key(modes::MODE.name, r)
            .unwrap_or_else(|| (r + 1).to_string());
        let Some(shape) = shape else {
            continue;
        };
        let chart = match &layout {
            Some(layout) => profile_chart(shape, &names, layout),
            None => list_chart(shape, &names),
        };
        let direction = t.key(modes::DIRECTION.name, r).unwrap_or_default();
        let mpc = num(modes::MPC.name, r);
        let complexity = match (mpc, num(modes::MPD_DEG.name, r)) {
            (Some(c), Some(d)) => format!(
                "; MPC {}, MPD {}°{}",
                format_number(c),
                format_number(d),
                if c < COMPLEX_MPC {
                    " — a complex shape: the real part drawn misrepresents it (see the imaginary parts below)"
                } else {
                    ""
                }
            ),
            _ => String::new(),
        };
        let caption = format!(
            "Mode {mode}: {} Hz, ζ = {} %{}{complexity}",
            num(modes::FREQUENCY_HZ.name, r)
                .map(format_number)
                .unwrap_or_else(|| "—".into()),
            num(modes::DAMPING_RATIO.name, r)
                .map(|z| format_number(100.0 * z))
                .unwrap_or_else(|| "—".into()),
            if direction.is_empty() {
                String::new()
            } else {
                format!(", {}", direction_text(&direction))
            }
        );
        let legend = plot::legend(&chart.series);
        body.push_str(&figure_with(
            &format!("class=\"mode-shape\" id=\"mode-shape-{}\"", escape(&mode)),
            plot::render(&chart),
            &caption,
            &legend,
        ));
    }
    body.push_str("</div>");
    // The numbers under their channel names.
    let mut headers = vec!["mode".to_string()];
    headers.extend(names.iter().cloned());
    let imaginary = list_column(t, modes::SHAPE_IM.name);
    let mut rows: Vec<Vec<Cell>> = Vec::new();
    for (r, s) in shapes.iter().enumerate() {
        let mode = t
            .key(modes::MODE.name, r)
            .unwrap_or_else(|| (r + 1).to_string());
        let parts = [("Re", Some(s)), ("Im", imaginary.and_then(|v| v.get(r)))];
        for (part, values) in parts {
            let Some(values) = values else { continue };
            let mut row = vec![Cell::text(&format!("{mode} ({part})"))];
            row.extend(
                (0..names.len())
                    .map(|i| Cell::number(values.as_ref().and_then(|v| v.get(i).copied()))),
            );
            rows.push(row);
        }
    }
    body.push_str(&format!(
        "<details><summary>Shape components (real and imaginary parts) by channel</summary><div class=\"scroll\">{}</div></details>",
        table(Some("mode-shape-table"), &headers, &rows)
    ));
    body
}

/// Storey profile: one series per (direction, k-th sensor of that
/// direction on its level), points sorted by level.
fn profile_chart(shape: &[f64], names: &[String], layout: &[(i32, String)]) -> Chart {
    let mut lines: BTreeMap<(String, usize), Vec<(f64, f64, &str)>> = BTreeMap::new();
    let mut count: BTreeMap<(String, i32), usize> = BTreeMap::new();
    for ((value, name), (level, dir)) in shape.iter().zip(names).zip(layout) {
        let k = count.entry((dir.clone(), *level)).or_default();
        lines
            .entry((dir.clone(), *k))
            .or_default()
            .push((*value, f64::from(*level), name));
        *k += 1;
    }
    let top = layout.iter().map(|l| l.0).max().unwrap_or(1).max(1);
    let mut chart = Chart::new(300, 300, "component (real part)", "level");
    chart.x_range = Some((-1.15, 1.15));
    chart.y_range = Some((-0.3, f64::from(top) + 0.5));
    chart.ref_lines.push(RefLine {
        at: 0.0,
        horizontal: false,
        colour: 6,
    });
    let label = names.len() <= MAX_LABELS;
    for (i, ((dir, k), mut pts)) in lines.into_iter().enumerate() {
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        if label {
            // Components near zero (the other direction of a mode) unnamed:
            // their labels would pile up on the axis.
            chart
                .annotations
                .extend(
                    pts.iter()
                        .filter(|p| p.0.abs() >= 0.05)
                        .map(|(x, y, n)| Annotation {
                            x: *x,
                            y: *y,
                            text: n.to_string(),
                            colour: i,
                        }),
                );
        }
        let name = if k == 0 {
            direction_text(&dir)
        } else {
            format!("{} (sensor {})", direction_text(&dir), k + 1)
        };
        chart.series.push(Series::new(
            name,
            pts.iter().map(|p| (p.0, p.1)).collect(),
            i,
            Mark::LinePoints,
        ));
    }
    chart
}

/// Components against their position in the channel list.
fn list_chart(shape: &[f64], names: &[String]) -> Chart {
    let mut chart = Chart::new(300, 260, "channel (position in the list)", "component");
    chart.x_range = Some((0.5, shape.len() as f64 + 0.5));
    chart.y_range = Some((-1.15, 1.15));
    chart.ref_lines.push(RefLine {
        at: 0.0,
        horizontal: true,
        colour: 6,
    });
    let pts: Vec<(f64, f64)> = shape
        .iter()
        .enumerate()
        .map(|(i, v)| ((i + 1) as f64, *v))
        .collect();
    if names.len() <= MAX_LABELS {
        chart
            .annotations
            .extend(pts.iter().zip(names).map(|(p, n)| Annotation {
                x: p.0,
                y: p.1,
                text: n.clone(),
                colour: 0,
            }));
    }
    chart
        .series
        .push(Series::new("component", pts, 0, Mark::FilledCircle));
    chart
}
