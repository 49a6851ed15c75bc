//! The lab-test report (issue 37): its own page for a run of the lab-test
//! pipeline — per lab record, the identified model (form and why, the
//! parameters with their standard deviations, force NRMSE, dissipated
//! energy per cycle, damage indices) and the measured loop with the fitted
//! one overlaid — then an appendix of the run's output files.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;

use super::appendix::{output_files, table_checks};
use super::{figure, load, section, Loaded};
use crate::report::html::{escape, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, lab_cycles, lab_fit, lab_identification};

/// The sections of the lab-test page, in order.
pub const SECTIONS: [(&str, &str); 2] = [
    ("lab", "Lab test: hysteresis identified from measured force"),
    ("appendix", "Appendix: output files"),
];

const STAGES: [&str; 2] = ["lab_hysteresis", "report"];

/// A lab-test run: the lab identification table is there.
pub(super) fn applies(dir: &Path) -> bool {
    matches!(
        load(dir, &tables::LAB_IDENTIFICATION, Some(&[])),
        Loaded::Ok(_)
    )
}

fn num(t: &crate::report::table::Table, c: &str, r: usize) -> Option<f64> {
    t.number(c).and_then(|v| v.get(r).copied().flatten())
}

/// Rows per record: (whole-history rows, `stft_instantaneous` rows). A
/// table without the `method` column (written before it) is all whole-history.
fn rows_by_record(t: &crate::report::table::Table) -> BTreeMap<String, (Vec<usize>, Vec<usize>)> {
    let mut m: BTreeMap<String, (Vec<usize>, Vec<usize>)> = BTreeMap::new();
    for r in 0..t.rows {
        if let Some(k) = t.key(lab_identification::RECORD.name, r) {
            let entry = m.entry(k).or_default();
            if t.key(lab_identification::METHOD.name, r).as_deref() == Some("stft_instantaneous") {
                entry.1.push(r);
            } else {
                entry.0.push(r);
            }
        }
    }
    m
}

fn parameter_rows(id: &crate::report::table::Table, rows: &[usize]) -> Vec<Vec<Cell>> {
    rows.iter()
        .map(|&r| {
            vec![
                Cell::text(
                    &id.key(lab_identification::PARAMETER.name, r)
                        .unwrap_or_default(),
                ),
                Cell::number(num(id, lab_identification::VALUE.name, r)),
                Cell::number(num(id, lab_identification::STD.name, r)),
                Cell::text(&id.key(lab_identification::UNIT.name, r).unwrap_or_default()),
                Cell::text(
                    if id
                        .boolean(lab_identification::FIXED.name)
                        .and_then(|b| b.get(r).copied().flatten())
                        == Some(true)
                    {
                        "fixed"
                    } else {
                        "fitted"
                    },
                ),
            ]
        })
        .collect()
}

/// The thesis's time–frequency identification of a dynamic record, beside
/// the whole-history fit.
fn instantaneous_block(id: &crate::report::table::Table, rows: &[usize]) -> String {
    let r0 = rows[0];
    let fmt = |v: Option<f64>| {
        v.map(crate::report::format_number)
            .unwrap_or_else(|| "—".into())
    };
    let reason = escape(
        &id.key(lab_identification::FORM_REASON.name, r0)
            .unwrap_or_default(),
    );
    if id.key(lab_identification::FORM.name, r0).as_deref() == Some("not_identified") {
        return format!(
            "<h4>The thesis's time–frequency identification (METHODS.md §4)</h4><p>Nothing identified: {reason}</p>"
        );
    }
    let mut out = format!(
        "<h4>The thesis's time–frequency identification (METHODS.md §4)</h4><dl class=\"facts\"><dt>Verdict</dt><dd>{reason}</dd><dt>Force NRMSE</dt><dd>{}</dd><dt>Mean |energy error| per cycle</dt><dd>{} over {} cycles</dd><dt>Saturation force (K0/(β+γ))^(1/N)</dt><dd>{} N</dd><dt>Damage index ι at the end (Eq. 34)</dt><dd>{}</dd></dl>",
        fmt(num(id, lab_identification::FORCE_NRMSE.name, r0)),
        fmt(num(id, lab_identification::ENERGY_ERROR_MEAN.name, r0)),
        fmt(num(id, lab_identification::CYCLES.name, r0)),
        fmt(num(id, lab_identification::YIELD_FORCE_N.name, r0)),
        fmt(num(id, lab_identification::STIFFNESS_INDEX.name, r0)),
    );
    out.push_str(&table(
        None,
        &["parameter", "value", "spread over time", "unit", ""].map(String::from),
        &parameter_rows(id, rows),
    ));
    out
}

/// The measured and fitted loops of one record (kN against mm).
fn loop_figure(
    fit: &crate::report::table::Table,
    record: &str,
    settings: &ReportSettings,
) -> String {
    let rows: Vec<usize> = (0..fit.rows)
        .filter(|&r| fit.key(lab_fit::RECORD.name, r).as_deref() == Some(record))
        .collect();
    let points = |col: &str| -> Vec<(f64, f64)> {
        rows.iter()
            .filter_map(|&r| {
                Some((
                    num(fit, lab_fit::DISPLACEMENT_M.name, r)? * 1e3,
                    num(fit, col, r)? * 1e-3,
                ))
            })
            .collect()
    };
    let mut chart = Chart::new(560, 380, "displacement (mm)", "force (kN)");
    chart.series.push(Series::new(
        "measured",
        plot::decimate_curve(
            &points(lab_fit::FORCE_MEASURED_N.name),
            settings.max_points_per_trace,
        ),
        0,
        Mark::Line,
    ));
    chart.series.push(Series::new(
        "identified model",
        plot::decimate_curve(
            &points(lab_fit::FORCE_FITTED_N.name),
            settings.max_points_per_trace,
        ),
        1,
        Mark::Line,
    ));
    let stft = points(lab_fit::FORCE_INSTANTANEOUS_N.name);
    if !stft.is_empty() {
        chart.series.push(Series::new(
            "thesis's STFT identification",
            plot::decimate_curve(&stft, settings.max_points_per_trace),
            2,
            Mark::Line,
        ));
    }
    let legend = plot::legend(&chart.series);
    figure(
        plot::render(&chart),
        &format!("{record}: measured force–displacement loop and the identified model's along the same displacement"),
        &legend,
    )
}

fn lab_body(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let id_loaded = load(dir, &tables::LAB_IDENTIFICATION, None);
    let Some(id) = super::require(&id_loaded, &tables::LAB_IDENTIFICATION, &mut body) else {
        return body;
    };
    let fit_loaded = load(dir, &tables::LAB_FIT, None);
    let cycles_loaded = load(dir, &tables::LAB_CYCLES, None);
    body.push_str(&note(
        "Bouc–Wen (plain) or Bouc–Wen–Baber–Noori (degrading/pinching) fitted to the measured displacement and force by least squares (docs/lab-tests.md, Eq. L1–L9); standard deviations from s²(JᵀJ)⁻¹ at the optimum, inflated for correlated residuals.",
    ));
    for (record, (rows, stft_rows)) in rows_by_record(id) {
        let Some(&r0) = rows.first() else { continue };
        body.push_str(&format!("<h3>{}</h3>", escape(&record)));
        let text = |c: &str| id.key(c, r0).unwrap_or_default();
        let fmt = |v: Option<f64>| {
            v.map(crate::report::format_number)
                .unwrap_or_else(|| "—".into())
        };
        body.push_str(&format!(
            "<dl class=\"facts\"><dt>Model form</dt><dd>{}</dd><dt>Why</dt><dd>{}</dd><dt>Force NRMSE</dt><dd>{} (plain model: {})</dd><dt>Mean |energy error| per cycle</dt><dd>{} over {} cycles</dd><dt>Yield force F_y = k₀u_y</dt><dd>{} N</dd><dt>Ductility max|x|/u_y</dt><dd>{}</dd><dt>Dissipated energy</dt><dd>{} J</dd><dt>Stiffness index 1 − √(k_end/k₀)</dt><dd>{}</dd><dt>Park–Ang</dt><dd>{}</dd></dl>",
            escape(&text(lab_identification::FORM.name)),
            escape(&text(lab_identification::FORM_REASON.name)),
            fmt(num(id, lab_identification::FORCE_NRMSE.name, r0)),
            fmt(num(id, lab_identification::PLAIN_NRMSE.name, r0)),
            fmt(num(id, lab_identification::ENERGY_ERROR_MEAN.name, r0)),
            fmt(num(id, lab_identification::CYCLES.name, r0)),
            fmt(num(id, lab_identification::YIELD_FORCE_N.name, r0)),
            fmt(num(id, lab_identification::DUCTILITY.name, r0)),
            fmt(num(id, lab_identification::HYSTERETIC_ENERGY_J.name, r0)),
            fmt(num(id, lab_identification::STIFFNESS_INDEX.name, r0)),
            match num(id, lab_identification::PARK_ANG.name, r0) {
                Some(v) => crate::report::format_number(v),
                None => "not computed (no ultimate displacement δ_u stated)".into(),
            },
        ));
        let params = parameter_rows(id, &rows);
        body.push_str(&table(
            None,
            &["parameter", "value", "std", "unit", ""].map(String::from),
            &params,
        ));
        if !stft_rows.is_empty() {
            body.push_str(&instantaneous_block(id, &stft_rows));
        }
        match &fit_loaded {
            Loaded::Ok(fit) => body.push_str(&loop_figure(fit, &record, settings)),
            _ => body.push_str(&note("No loops: the fitted-loop table is absent.")),
        }
        if let Loaded::Ok(cy) = &cycles_loaded {
            let rows: Vec<Vec<Cell>> = (0..cy.rows)
                .filter(|&r| cy.key(lab_cycles::RECORD.name, r).as_deref() == Some(record.as_str()))
                .map(|r| {
                    vec![
                        Cell::number(num(cy, lab_cycles::CYCLE.name, r)),
                        Cell::number(num(cy, lab_cycles::AMPLITUDE_M.name, r).map(|v| v * 1e3)),
                        Cell::number(num(cy, lab_cycles::ENERGY_MEASURED_J.name, r)),
                        Cell::number(num(cy, lab_cycles::ENERGY_FITTED_J.name, r)),
                        Cell::number(num(cy, lab_cycles::ENERGY_ERROR.name, r).map(|v| v * 100.0)),
                    ]
                })
                .collect();
            if !rows.is_empty() {
                body.push_str("<details><summary>Dissipated energy per cycle</summary>");
                body.push_str(&table(
                    None,
                    &[
                        "cycle",
                        "peak-to-peak (mm)",
                        "measured (J)",
                        "fitted (J)",
                        "error (%)",
                    ]
                    .map(String::from),
                    &rows,
                ));
                body.push_str("</details>");
            }
        }
    }
    body
}

/// The whole lab-test page.
pub(super) fn page(dir: &Path, event: &Result<Value, String>, settings: &ReportSettings) -> String {
    let title = settings
        .title
        .clone()
        .unwrap_or_else(|| "Lab test: hysteresis identification".to_string());
    let mut appendix = output_files(dir, Some(&STAGES));
    appendix.push_str(&table_checks());
    let mut page = String::with_capacity(1 << 18);
    page.push_str(&super::page_head(&title));
    page.push_str(&super::page_header(dir, event, &title, settings, &SECTIONS));
    for (i, ((sid, t), body)) in SECTIONS
        .iter()
        .zip([lab_body(dir, settings), appendix])
        .enumerate()
    {
        page.push_str(&section(sid, i + 1, t, &body));
    }
    page.push_str(&format!(
        "</main>\n<footer><p>{}</p></footer>\n</body>\n</html>\n",
        escape("Every number on this page is read from the outputs of the run in the directory above (the appendix lists them).")
    ));
    page
}
