//! Modal identification: stabilisation diagram with the modal spectrum (PSD
//! singular values) under it on the same frequency axis, the identified
//! modes, their shapes (`mode_shapes`) and the frequency shift against a
//! reference event.

use std::path::Path;

use super::{figure, load, require, Loaded, Outputs};
use crate::modal::uncertainty;
use crate::report::html::{
    cells, column_notes, escape, format_number, missing_columns_note, note, table, Cell,
};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{self, frequency_shifts, modal_spectrum, modes, stabilization};

/// PSD singular values drawn (σ1 … σ4): the leading ones carry the modes.
const SPECTRUM_LINES: usize = 4;

/// Decades of the strongest PSD singular value the spectrum's axis spans.
const SPECTRUM_DECADES: f64 = 8.0;

/// Width and y-label area shared by the stabilisation diagram and the modal
/// spectrum, so their frequency axes line up.
const MODAL_WIDTH: u32 = 900;
const MODAL_Y_AREA: u32 = 78;

pub(super) fn modal_section(dir: &Path, o: &Outputs, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let stab = load(dir, &tables::STABILIZATION, None);
    let spectrum = load(dir, &tables::MODAL_SPECTRUM, None);
    let (modes, shifts) = (&o.modes, &o.shifts);
    let mode_freqs: Vec<f64> = match modes {
        Loaded::Ok(m) => m
            .number(modes::FREQUENCY_HZ.name)
            .map(|v| v.iter().flatten().copied().collect())
            .unwrap_or_default(),
        _ => Vec::new(),
    };

    // The frequency axis of both charts: 0 to the highest pole.
    let f_axis = match &stab {
        Loaded::Ok(t) => t
            .number(stabilization::FREQUENCY_HZ.name)
            .map(|f| f.iter().flatten().fold(0.0f64, |a, b| a.max(*b)))
            .filter(|m| *m > 0.0)
            .map(|m| (0.0, 1.03 * m)),
        _ => None,
    };
    body.push_str("<h3>Stabilisation diagram and modal spectrum</h3>");
    if let Some(t) = require(&stab, &tables::STABILIZATION, &mut body) {
        let known = [
            stabilization::ORDER.name,
            stabilization::FREQUENCY_HZ.name,
            stabilization::DAMPING_RATIO.name,
            stabilization::MPC.name,
            stabilization::MPD_DEG.name,
            stabilization::STABLE_FREQUENCY.name,
            stabilization::STABLE_DAMPING.name,
            stabilization::STABLE_SHAPE.name,
            stabilization::PHYSICAL.name,
            stabilization::MODE.name,
        ];
        body.push_str(&column_notes(t, &known));
        if t.has(stabilization::ORDER.name) && t.has(stabilization::FREQUENCY_HZ.name) {
            let flag = |name: &str, r: usize| {
                t.boolean(name)
                    .and_then(|v| v.get(r).copied().flatten())
                    .unwrap_or(false)
            };
            let has_physical = t.has(stabilization::PHYSICAL.name);
            // Categories, worst first; a pole falls in the first that applies.
            let mut cats: [Vec<(f64, f64)>; 4] = Default::default();
            let (Some(fcol), Some(ocol)) = (
                t.number(stabilization::FREQUENCY_HZ.name),
                t.number(stabilization::ORDER.name),
            ) else {
                return body;
            };
            for r in 0..t.rows {
                let (Some(f), Some(o)) = (
                    fcol.get(r).copied().flatten(),
                    ocol.get(r).copied().flatten(),
                ) else {
                    continue;
                };
                let physical = !has_physical || flag(stabilization::PHYSICAL.name, r);
                let idx = if !physical {
                    3
                } else if flag(stabilization::STABLE_FREQUENCY.name, r)
                    && flag(stabilization::STABLE_DAMPING.name, r)
                    && flag(stabilization::STABLE_SHAPE.name, r)
                {
                    0
                } else if flag(stabilization::STABLE_FREQUENCY.name, r) {
                    1
                } else {
                    2
                };
                cats[idx].push((f, o));
            }
            let labels = [
                (
                    "stable in frequency, damping and shape",
                    Mark::FilledCircle,
                    0,
                ),
                ("stable in frequency only", Mark::HollowCircle, 2),
                ("new or unstable", Mark::Cross, 4),
                ("non-physical (filtered out)", Mark::Triangle, 6),
            ];
            let mut chart = Chart::new(MODAL_WIDTH, 380, "frequency (Hz)", "model order");
            chart.x_range = f_axis;
            chart.y_label_area = Some(MODAL_Y_AREA);
            for (i, pts) in cats.into_iter().enumerate() {
                let (label, mark, colour) = labels[i];
                chart.series.push(Series::new(
                    format!("{label} ({})", pts.len()),
                    pts,
                    colour,
                    mark,
                ));
            }
            for f in &mode_freqs {
                chart.ref_lines.push(RefLine {
                    at: *f,
                    horizontal: false,
                    colour: 1,
                });
            }
            let mut legend_series = chart.series.clone();
            if !mode_freqs.is_empty() {
                legend_series.push(Series::new("identified mode", vec![], 1, Mark::Dashed));
            }
            let bars = error_bars(modes);
            if !bars.is_empty() {
                legend_series.push(Series::new(
                    "95 % interval f ± t σ (data-driven σ, Student's t of its degrees of freedom), above the mode's column",
                    vec![],
                    1,
                    Mark::Line,
                ));
            }
            let top = ocol.iter().flatten().fold(0.0f64, |a, b| a.max(*b));
            for (f, half, order) in &bars {
                chart.series.push(Series::new(
                    "",
                    error_bar(
                        *f,
                        *half,
                        (order + 2.0).min(top + 1.0),
                        0.01 * top.max(10.0),
                    ),
                    1,
                    Mark::Line,
                ));
            }
            body.push_str(&figure(
                plot::render(&chart),
                &format!("Stabilisation diagram: {} poles", t.rows),
                &plot::legend(&legend_series),
            ));
        }
    }
    if let Some(t) = require(&spectrum, &tables::MODAL_SPECTRUM, &mut body) {
        body.push_str(&spectrum_figure(t, f_axis, &mode_freqs));
    }

    body.push_str("<h3>Identified modes</h3>");
    if let Loaded::Ok(t) = modes {
        // Why no mode, or fewer than the stable columns suggest (issue 13).
        let warnings: Vec<String> = t
            .metadata
            .get("quaketwin.warnings")
            .and_then(|w| serde_json::from_str(w).ok())
            .unwrap_or_default();
        for w in &warnings {
            body.push_str(&format!(
                "<p class=\"warning\">Warning: {}</p>",
                crate::report::html::escape(w)
            ));
        }
    }
    if let Some(t) = require(modes, &tables::MODES, &mut body) {
        let known = [
            modes::MODE.name,
            modes::FREQUENCY_HZ.name,
            modes::FREQUENCY_STD_HZ.name,
            modes::DAMPING_RATIO.name,
            modes::DAMPING_STD.name,
            modes::FREQUENCY_STD_DATA_HZ.name,
            modes::DAMPING_STD_DATA.name,
            modes::UNCERTAINTY_BLOCKS.name,
            modes::UNCERTAINTY_DOF.name,
            modes::UNCERTAINTY_BASIS.name,
            modes::DIRECTION.name,
            modes::MPC.name,
            modes::MPD_DEG.name,
            modes::MEAN_MAC.name,
            modes::POLE_COUNT.name,
            modes::ORDER_MIN.name,
            modes::ORDER_MAX.name,
            modes::MANUAL.name,
        ];
        body.push_str(&missing_columns_note(t, &known));
        // Shapes are drawn below, with their channel names, not listed here.
        let shape_columns = [
            modes::SHAPE_RE.name,
            modes::SHAPE_IM.name,
            modes::SHAPE_STD.name,
        ];
        let cols: Vec<String> = known
            .iter()
            .filter(|c| t.has(c))
            .map(|c| c.to_string())
            .chain(
                t.unknown(&known)
                    .into_iter()
                    .filter(|c| !shape_columns.contains(&c.as_str())),
            )
            .collect();
        let rows: Vec<Vec<Cell>> = cells(t, &cols, settings.max_table_rows)
            .into_iter()
            .enumerate()
            .map(|(r, mut row)| {
                if let Some(i) = cols.iter().position(|c| c == modes::DIRECTION.name) {
                    row[i] = Cell::direction(t, modes::DIRECTION.name, r);
                }
                row
            })
            .collect();
        body.push_str(&format!(
            "<div class=\"scroll\">{}</div>",
            table(Some("modes-table"), &cols, &rows)
        ));
        body.push_str("<h3>Mode shapes</h3>");
        body.push_str(&super::mode_shapes::mode_shapes(t, &o.channels));
    }

    body.push_str("<h3>Frequency shift against a reference event</h3>");
    body.push_str(&shifts_part(shifts, settings));
    body
}

/// (f, half-width of the 95 % interval, highest order of the column) of
/// every mode of `modes` with a data-driven σ (`frequency_std_data_hz`):
/// the half-width is t_{0.975, ν} σ, ν = `uncertainty_dof` (Eqs. S8–S8'
/// of docs/statistics.md; `uncertainty_blocks` − 1 for a table without
/// it, 2σ for a table without either).
fn error_bars(modes: &Loaded) -> Vec<(f64, f64, f64)> {
    let Loaded::Ok(t) = modes else {
        return Vec::new();
    };
    let (Some(f), Some(sd), Some(order)) = (
        t.number(modes::FREQUENCY_HZ.name),
        t.number(modes::FREQUENCY_STD_DATA_HZ.name),
        t.number(modes::ORDER_MAX.name),
    ) else {
        return Vec::new();
    };
    let blocks = t.number(modes::UNCERTAINTY_BLOCKS.name);
    // Tables written before Eq. S8' have no dof column: blocks − 1.
    let dof = t.number(modes::UNCERTAINTY_DOF.name);
    (0..t.rows)
        .filter_map(|r| {
            let v = |c: &[Option<f64>]| c.get(r).copied().flatten();
            let factor = dof
                .and_then(v)
                .or_else(|| blocks.and_then(v).map(|b| b - 1.0))
                .map_or(2.0, uncertainty::interval_factor);
            Some((v(f)?, factor * v(sd)?, v(order)?))
        })
        .filter(|(f, half, _)| f.is_finite() && half.is_finite() && *half >= 0.0)
        .collect()
}

/// An error bar from f − half to f + half at height y, with end caps of
/// height ±cap: one polyline.
fn error_bar(f: f64, half: f64, y: f64, cap: f64) -> Vec<(f64, f64)> {
    vec![
        (f - half, y - cap),
        (f - half, y + cap),
        (f - half, y),
        (f + half, y),
        (f + half, y + cap),
        (f + half, y - cap),
    ]
}

/// The leading singular values of the PSD matrix against frequency (log
/// scale), on the stabilisation diagram's frequency axis, with the
/// identified frequencies; the subspace singular values in a note.
fn spectrum_figure(t: &Table, f_axis: Option<(f64, f64)>, mode_freqs: &[f64]) -> String {
    let known = [
        modal_spectrum::KIND.name,
        modal_spectrum::INDEX.name,
        modal_spectrum::FREQUENCY_HZ.name,
        modal_spectrum::VALUE.name,
    ];
    let mut html = column_notes(t, &known);
    let (Some(index), Some(freq), Some(value)) = (
        t.number(modal_spectrum::INDEX.name),
        t.number(modal_spectrum::FREQUENCY_HZ.name),
        t.number(modal_spectrum::VALUE.name),
    ) else {
        return html;
    };
    let kind = |r: usize| t.key(modal_spectrum::KIND.name, r);
    let (lo, hi) = f_axis.unwrap_or((0.0, f64::INFINITY));
    let mut lines: Vec<Vec<(f64, f64)>> = vec![Vec::new(); SPECTRUM_LINES];
    for r in 0..t.rows {
        if kind(r).as_deref() != Some("psd") {
            continue;
        }
        let (Some(i), Some(f), Some(v)) = (index[r], freq[r], value[r]) else {
            continue;
        };
        let i = i as usize;
        if (1..=SPECTRUM_LINES).contains(&i) && f >= lo && f <= hi && v > 0.0 {
            lines[i - 1].push((f, v));
        }
    }
    let top = lines.iter().flatten().map(|p| p.1).fold(0.0f64, f64::max);
    if top <= 0.0 {
        html.push_str(&note(
            "The modal spectrum holds no PSD singular values to plot.",
        ));
        return html;
    }
    let mut chart = Chart::new(MODAL_WIDTH, 260, "frequency (Hz)", "PSD singular value");
    chart.log_y = true;
    chart.x_range = f_axis;
    chart.y_range = Some((top * 10f64.powf(-SPECTRUM_DECADES), 2.0 * top));
    chart.y_label_area = Some(MODAL_Y_AREA);
    for (i, pts) in lines.into_iter().enumerate() {
        if !pts.is_empty() {
            chart
                .series
                .push(Series::new(format!("σ{}", i + 1), pts, i, Mark::Line));
        }
    }
    for f in mode_freqs {
        chart.ref_lines.push(RefLine {
            at: *f,
            horizontal: false,
            colour: 1,
        });
    }
    let legend = plot::legend(&chart.series);
    html.push_str(&figure(
        plot::render(&chart),
        "Modal spectrum: leading singular values of the Welch PSD matrix of the outputs on the \
         frequency axis of the stabilisation diagram above; dashed: identified modes. Peaks of σ1 mark modes; σ2 rising \
         to σ1 marks close modes.",
        &legend,
    ));
    html
}

/// The pre/post table: reference vs this event, shift ± σ, MAC, significant;
/// then what the pairing was based on and the notes (unpaired modes…).
fn shifts_part(shifts: &Loaded, settings: &ReportSettings) -> String {
    use frequency_shifts as fs;
    let mut body = String::new();
    if let Loaded::Absent(None) = shifts {
        body.push_str("<p class=\"absent\">Not computed: no earlier event of the same structure was given to compare with (the modal stage compares with one given by <code>--reference DIR</code> or its <code>reference_modes</code> param).</p>");
        return body;
    }
    let Loaded::Ok(t) = shifts else {
        require(shifts, &tables::FREQUENCY_SHIFTS, &mut body);
        return body;
    };
    let meta = |k: &str| t.metadata.get(k).cloned().unwrap_or_default();
    let mut facts = format!(
        "Reference: <code>{}</code>",
        escape(&meta("quaketwin.reference"))
    );
    if let Ok(c) = serde_json::from_str::<Vec<String>>(&meta("quaketwin.shared_channels")) {
        facts.push_str(&format!(
            "; {} shared channel(s): {}",
            c.len(),
            escape(&c.join(", "))
        ));
    }
    if let Ok(p) = serde_json::from_str::<serde_json::Value>(&meta("quaketwin.pairing")) {
        let basis = p["basis"].as_str().unwrap_or("");
        facts.push_str(&match basis {
            "frequency_and_direction" => format!(
                "; paired by frequency (within {} %) and direction label only (fewer than 2 shared channels: no MAC)",
                100.0 * p["frequency_window"].as_f64().unwrap_or(f64::NAN)
            ),
            _ => format!(
                "; paired by MAC ≥ {} on the shared channels and frequency within {} %",
                p["min_mac"].as_f64().unwrap_or(f64::NAN),
                100.0 * p["frequency_window"].as_f64().unwrap_or(f64::NAN)
            ),
        });
    }
    body.push_str(&format!("<p>{facts}.</p>"));
    if let Some(t) = require(shifts, &tables::FREQUENCY_SHIFTS, &mut body) {
        let known = [
            fs::REFERENCE_MODE.name,
            fs::FREQUENCY_REFERENCE_HZ.name,
            fs::CURRENT_MODE.name,
            fs::FREQUENCY_CURRENT_HZ.name,
            fs::DIRECTION_CURRENT.name,
            fs::SHIFT_PERCENT.name,
            fs::SHIFT_STD_PERCENT.name,
            fs::SHIFT_STD_BASIS.name,
            fs::MAC.name,
            fs::SIGNIFICANT.name,
            fs::SHIFT_DOF.name,
            fs::DAMPING_REFERENCE.name,
            fs::DAMPING_CURRENT.name,
        ];
        body.push_str(&missing_columns_note(t, &known));
        let num = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
        let headers: Vec<String> = [
            "reference mode",
            "f reference (Hz)",
            "mode",
            "f (Hz)",
            "direction",
            "shift ± σ (%)",
            "σ from",
            "MAC",
            "significant (|shift| > t σ, 95 %)",
            "damping reference → this event",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect();
        let rows: Vec<Vec<Cell>> = (0..t.rows.min(settings.max_table_rows))
            .map(|r| {
                let shift = num(fs::SHIFT_PERCENT.name, r);
                let pm = |v: Option<f64>, sd: Option<f64>| match (v, sd) {
                    (Some(v), Some(sd)) => {
                        format!("{} ± {}", format_number(v), format_number(sd))
                    }
                    (Some(v), None) => format_number(v),
                    _ => "—".into(),
                };
                // With the factor of the test beside the verdict: Student's
                // t of the shift's degrees of freedom (Eq. S8'), 2 without them.
                let factor = num(fs::SHIFT_DOF.name, r).map_or(String::new(), |dof| {
                    format!(
                        " (t = {:.2}, {:.1} dof)",
                        uncertainty::interval_factor(dof),
                        dof
                    )
                });
                let significant = match t
                    .boolean(fs::SIGNIFICANT.name)
                    .and_then(|v| v.get(r).copied().flatten())
                {
                    Some(true) if shift.is_some_and(|s| s < 0.0) => format!("yes: drop{factor}"),
                    Some(true) => format!("yes: rise{factor}"),
                    Some(false) => format!("no{factor}"),
                    None => "unknown (no frequency std)".to_string(),
                };
                vec![
                    Cell::of(t, fs::REFERENCE_MODE.name, r),
                    Cell::raw(pm(
                        num(fs::FREQUENCY_REFERENCE_HZ.name, r),
                        num(fs::FREQUENCY_REFERENCE_STD_DATA_HZ.name, r)
                            .or(num(fs::FREQUENCY_REFERENCE_STD_HZ.name, r)),
                    )),
                    Cell::of(t, fs::CURRENT_MODE.name, r),
                    Cell::raw(pm(
                        num(fs::FREQUENCY_CURRENT_HZ.name, r),
                        num(fs::FREQUENCY_CURRENT_STD_DATA_HZ.name, r)
                            .or(num(fs::FREQUENCY_CURRENT_STD_HZ.name, r)),
                    )),
                    Cell::direction(t, fs::DIRECTION_CURRENT.name, r),
                    Cell {
                        value: shift,
                        class: Some("num"),
                        ..Cell::raw(pm(shift, num(fs::SHIFT_STD_PERCENT.name, r)))
                    },
                    Cell::text(
                        match t
                            .text(fs::SHIFT_STD_BASIS.name)
                            .and_then(|v| v.get(r).cloned().flatten())
                            .as_deref()
                        {
                            Some("data") => "data (both records)",
                            Some("mixed") => "data (one record), order spread (other)",
                            Some("order_spread") => "order spread (floored)",
                            _ => "—",
                        },
                    ),
                    Cell::of(t, fs::MAC.name, r),
                    Cell::text(&significant),
                    Cell::raw(format!(
                        "{} → {}",
                        pm(num(fs::DAMPING_REFERENCE.name, r), None),
                        pm(num(fs::DAMPING_CURRENT.name, r), None)
                    )),
                ]
            })
            .collect();
        body.push_str(&format!(
            "<div class=\"scroll\">{}</div>",
            table(Some("shifts-table"), &headers, &rows)
        ));
    }
    let notes: Vec<String> = serde_json::from_str(&meta("quaketwin.notes")).unwrap_or_default();
    if !notes.is_empty() {
        body.push_str("<ul class=\"note\">");
        for n in &notes {
            body.push_str(&format!("<li>{}</li>", escape(n)));
        }
        body.push_str("</ul>");
    }
    body
}
