//! Section 7, modal identification: stabilisation diagram, identified modes and
//! the frequency shift against a reference event.

use std::path::Path;

use super::{figure, known_columns_first, load, require, Loaded};
use crate::report::html::{cells, column_notes, missing_columns_note, table};
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
    match &shifts {
        Loaded::Absent(_) => body.push_str(&format!(
            "<p class=\"absent\">Output absent: <code>frequency_shifts.parquet</code> (written by the modal stage only when a previous event of the same structure is given).</p>"
        )),
        _ => {
            if let Some(t) = require(&shifts, &tables::FREQUENCY_SHIFTS, &mut body) {
                let known = [
                    frequency_shifts::REFERENCE_MODE.name,
                    frequency_shifts::OTHER_MODE.name,
                    frequency_shifts::FREQUENCY_REFERENCE_HZ.name,
                    frequency_shifts::FREQUENCY_OTHER_HZ.name,
                    frequency_shifts::RELATIVE_SHIFT.name,
                    frequency_shifts::MAC.name,
                ];
                body.push_str(&column_notes(t, &known));
                let cols = known_columns_first(t, &known);
                let rows = cells(t, &cols, settings.max_table_rows);
                body.push_str(&table(Some("shifts-table"), &cols, &rows));
            }
        }
    }
    body
}
