//! Section 7, modal identification: stabilisation diagram, identified modes and
//! the frequency shift against a reference event.

use std::path::Path;

use super::{figure, known_columns_first, load, require, Loaded};
use crate::report::html::{
    cells, column_notes, escape, format_number, missing_columns_note, table, Cell,
};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, frequency_shifts, modes, stabilization};

pub(super) fn modal_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let stab = load(dir, &tables::STABILIZATION, None);
    let modes = load(dir, &tables::MODES, None);
    let shifts = load(dir, &tables::FREQUENCY_SHIFTS, None);
    let mode_freqs: Vec<f64> = match &modes {
        Loaded::Ok(m) => m
            .number(modes::FREQUENCY_HZ.name)
            .map(|v| v.iter().flatten().copied().collect())
            .unwrap_or_default(),
        _ => Vec::new(),
    };

    body.push_str("<h3>Stabilisation diagram</h3>");
    if let Some(t) = require(&stab, &tables::STABILIZATION, &mut body) {
        let known = [
            stabilization::ORDER.name,
            stabilization::FREQUENCY_HZ.name,
            stabilization::DAMPING_RATIO.name,
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
            let mut chart = Chart::new(900, 380, "frequency (Hz)", "model order");
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
                legend_series.push(Series::new(
                    "identified mode (modes.parquet)",
                    vec![],
                    1,
                    Mark::Dashed,
                ));
            }
            body.push_str(&figure(
                plot::render(&chart),
                &format!("Stabilisation diagram: {} poles", t.rows),
                &plot::legend(&legend_series),
            ));
        }
    }

    body.push_str("<h3>Identified modes</h3>");
    if let Loaded::Ok(t) = &modes {
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
    if let Some(t) = require(&modes, &tables::MODES, &mut body) {
        let known = [
            modes::MODE.name,
            modes::FREQUENCY_HZ.name,
            modes::FREQUENCY_STD_HZ.name,
            modes::DAMPING_RATIO.name,
            modes::DAMPING_STD.name,
            modes::MPC.name,
            modes::MPD_DEG.name,
            modes::POLE_COUNT.name,
        ];
        body.push_str(&missing_columns_note(t, &known));
        let known = [&known[..], &["direction"]].concat();
        let cols = known_columns_first(t, &known);
        let rows = cells(t, &cols, settings.max_table_rows);
        body.push_str(&format!(
            "<div class=\"scroll\">{}</div>",
            table(Some("modes-table"), &cols, &rows)
        ));
    }

    body.push_str("<h3>Frequency shift against a reference event</h3>");
    body.push_str(&shifts_part(&shifts, settings));
    body
}

/// The pre/post table: reference vs this event, shift ± σ, MAC, significant;
/// then what the pairing was based on and the notes (unpaired modes…).
fn shifts_part(shifts: &Loaded, settings: &ReportSettings) -> String {
    use frequency_shifts as fs;
    let mut body = String::new();
    if let Loaded::Absent(None) = shifts {
        body.push_str("<p class=\"absent\">Output absent: <code>frequency_shifts.parquet</code> (written by the modal stage only when an earlier run of the same structure is given: <code>--reference DIR</code> or the <code>reference_modes</code> param).</p>");
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
            fs::MAC.name,
            fs::SIGNIFICANT.name,
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
            "MAC",
            "significant (|shift| > 2σ)",
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
                let significant = match t
                    .boolean(fs::SIGNIFICANT.name)
                    .and_then(|v| v.get(r).copied().flatten())
                {
                    Some(true) if shift.is_some_and(|s| s < 0.0) => "yes: drop",
                    Some(true) => "yes: rise",
                    Some(false) => "no",
                    None => "unknown (no frequency std)",
                };
                vec![
                    Cell::of(t, fs::REFERENCE_MODE.name, r),
                    Cell::raw(pm(
                        num(fs::FREQUENCY_REFERENCE_HZ.name, r),
                        num(fs::FREQUENCY_REFERENCE_STD_HZ.name, r),
                    )),
                    Cell::of(t, fs::CURRENT_MODE.name, r),
                    Cell::raw(pm(
                        num(fs::FREQUENCY_CURRENT_HZ.name, r),
                        num(fs::FREQUENCY_CURRENT_STD_HZ.name, r),
                    )),
                    Cell::of(t, fs::DIRECTION_CURRENT.name, r),
                    Cell {
                        value: shift,
                        class: Some("num"),
                        ..Cell::raw(pm(shift, num(fs::SHIFT_STD_PERCENT.name, r)))
                    },
                    Cell::of(t, fs::MAC.name, r),
                    Cell::text(significant),
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
