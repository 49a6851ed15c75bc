//! Damage index ι(t) (damage/damage.parquet): ratings per direction, ι(t) and
//! natural-frequency ratio charts on the page's common time axis.

use std::collections::BTreeMap;

use super::{figure, rating_cell, require, rows_points, time_series_figure, Outputs};
use crate::report::html::{column_notes, note, short_number, table, Cell};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::Table;
use crate::report::{Assessment, IotaStatistic, ReportSettings};
use crate::vocab::tables::{self, damage};

/// Columns damage/damage.parquet may hold besides the wide layout's `omega_ratio_<mode>`.
const KNOWN_COLUMNS: [&str; 7] = [
    damage::DIRECTION.name,
    damage::T_S.name,
    damage::IOTA.name,
    damage::MODE.name,
    damage::OMEGA_RAD_S.name,
    damage::OMEGA_RATIO.name,
    damage::PARTICIPATION.name,
];

/// Final and peak ι per direction (the summary's rows).
pub(super) fn iota_by_direction(t: &Table) -> Vec<(String, Option<f64>, Option<f64>)> {
    if t.number(damage::T_S.name).is_none() || t.number(damage::IOTA.name).is_none() {
        return Vec::new();
    }
    let long = t.has(damage::MODE.name) && t.number(damage::MODE.name).is_some();
    direction_groups(t)
        .into_iter()
        .map(|(key, rows)| {
            let modes = if long {
                mode_groups(t, &rows)
            } else {
                Vec::new()
            };
            let iota_rows: &[usize] = modes.first().map(|g| g.1.as_slice()).unwrap_or(&rows);
            let pts = rows_points(t, iota_rows, damage::T_S.name, damage::IOTA.name);
            let (final_v, peak_v) = final_and_peak(&pts);
            (key.join(""), final_v, peak_v)
        })
        .collect()
}

/// ι at the latest time and max over time of ι(t).
fn final_and_peak(pts: &[(f64, f64)]) -> (Option<f64>, Option<f64>) {
    let final_v = pts.iter().max_by(|a, b| a.0.total_cmp(&b.0)).map(|p| p.1);
    let peak_v = pts
        .iter()
        .map(|p| p.1)
        .filter(|v| v.is_finite())
        .reduce(f64::max);
    (final_v, peak_v)
}

/// Why damage/damage.parquet is empty (the damage stage writes no row when no
/// direction was identified).
pub(super) const NO_ROWS: &str = "No damage index ι(t): ι needs a direction whose Bouc-Wen model is identified (see the Bouc-Wen section)";

pub(super) fn damage_section(
    o: &Outputs,
    settings: &ReportSettings,
    out: &mut Vec<Assessment>,
) -> String {
    let mut body = String::new();
    if matches!(&o.damage, super::Loaded::Ok(t) if t.rows == 0) {
        return note(&format!("{NO_ROWS}."));
    }
    let Some(t) = require(&o.damage, &tables::DAMAGE, &mut body) else {
        return body;
    };
    // Two layouts: long (one row per direction, time and `mode`, with
    // `omega_ratio`) or wide (`omega_ratio_<mode>` columns).
    let long = t.has(damage::MODE.name) && t.number(damage::MODE.name).is_some();
    let ratio_cols = frequency_ratio_columns(t, long);
    let mut all_known: Vec<&str> = KNOWN_COLUMNS.to_vec();
    all_known.extend(ratio_cols.iter().map(|s| s.as_str()));
    body.push_str(&column_notes(t, &all_known));
    if t.number(damage::T_S.name).is_none() || t.number(damage::IOTA.name).is_none() {
        return body;
    }
    let th = settings.iota;
    body.push_str(&note(&format!(
        "Rating of the {} value of ι(t): GREEN < {} ≤ YELLOW < {} ≤ RED.",
        settings.iota_statistic.name(),
        short_number(th.yellow),
        short_number(th.red)
    )));
    let mut rows_html = Vec::new();
    let mut figures = String::new();
    for (gi, (key, rows)) in direction_groups(t).iter().enumerate() {
        let dir = key.join("");
        let modes = if long {
            mode_groups(t, rows)
        } else {
            Vec::new()
        };
        // In the long layout ι repeats on every mode's row: take one mode's rows.
        let iota_rows: &[usize] = modes.first().map(|g| g.1.as_slice()).unwrap_or(rows);
        let pts = rows_points(t, iota_rows, damage::T_S.name, damage::IOTA.name);
        rows_html.push(rate_direction(&dir, &pts, settings, out));
        figures.push_str(&iota_figure(&dir, &pts, gi, o.time_axis, settings));
        let ratios: Vec<(String, Vec<(f64, f64)>)> = if long && t.has(damage::OMEGA_RATIO.name) {
            modes
                .iter()
                .map(|(label, r)| {
                    (
                        label.clone(),
                        rows_points(t, r, damage::T_S.name, damage::OMEGA_RATIO.name),
                    )
                })
                .collect()
        } else {
            ratio_cols
                .iter()
                .map(|c| (c.clone(), rows_points(t, rows, damage::T_S.name, c)))
                .collect()
        };
        figures.push_str(&ratio_figure(&dir, ratios, o.time_axis, settings));
    }
    if let Some(steps) = t.metadata.get("quaketwin.indefinite_steps") {
        // {"X": 0, "Y": 3}: per direction, in words.
        let text = match serde_json::from_str::<serde_json::Value>(steps) {
            Ok(serde_json::Value::Object(m)) => m
                .iter()
                .map(|(d, n)| format!("direction {d}: {n}"))
                .collect::<Vec<_>>()
                .join("; "),
            _ => steps.clone(),
        };
        body.push_str(&note(&format!(
            "Time steps where the stiffness K(t) lost positive definiteness: {text}."
        )));
    }
    body.push_str(&table(
        Some("damage-table"),
        &[damage::DIRECTION.name, "final ι", "peak ι", "rating"].map(String::from),
        &rows_html,
    ));
    body.push_str(&format!("<div class=\"grid2\">{figures}</div>"));
    body.push_str(&note(
        "ι(t) includes recoverable energy and can oscillate during shaking (METHODS.md §4); the final value is the post-event state.",
    ));
    body
}

/// Numeric `omega_ratio…` columns: the wide layout's `omega_ratio_<mode>` (in the
/// long layout the single `omega_ratio` column is charted per mode instead).
fn frequency_ratio_columns(t: &Table, long: bool) -> Vec<String> {
    t.names
        .iter()
        .filter(|n| n.starts_with(damage::OMEGA_RATIO.name) && t.number(n).is_some())
        .filter(|n| !long || n.as_str() != damage::OMEGA_RATIO.name)
        .cloned()
        .collect()
}

/// Rows per direction (file order), or all rows as direction "—" without a
/// `direction` column.
fn direction_groups(t: &Table) -> Vec<(Vec<String>, Vec<usize>)> {
    let keys: Vec<&str> = if t.has(damage::DIRECTION.name) {
        vec![damage::DIRECTION.name]
    } else {
        vec![]
    };
    if keys.is_empty() {
        vec![(vec!["—".to_string()], (0..t.rows).collect::<Vec<_>>())]
    } else {
        t.groups(&keys)
    }
}

/// The long layout's `rows` of one direction grouped by mode ("mode k", ascending k).
fn mode_groups(t: &Table, rows: &[usize]) -> Vec<(String, Vec<usize>)> {
    let mut m: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    let modes = t.number(damage::MODE.name).unwrap_or(&[]);
    for &r in rows {
        if let Some(Some(k)) = modes.get(r) {
            m.entry(*k as i64).or_default().push(r);
        }
    }
    m.into_iter()
        .map(|(k, v)| (format!("mode {k}"), v))
        .collect()
}

/// The damage table's row of one direction (final ι, peak ι, rating of the chosen
/// statistic); a rated value is added to the assessments.
fn rate_direction(
    dir: &str,
    pts: &[(f64, f64)],
    settings: &ReportSettings,
    out: &mut Vec<Assessment>,
) -> Vec<Cell> {
    let stat = settings.iota_statistic;
    let (final_v, peak_v) = final_and_peak(pts);
    let rated = match stat {
        IotaStatistic::Final => final_v,
        IotaStatistic::Peak => peak_v,
    };
    let rating = rated.and_then(|v| settings.iota.rate(v));
    if let (Some(v), Some(rating)) = (rated, rating) {
        out.push(Assessment {
            criterion: format!("damage index ι ({})", stat.name()),
            subject: format!("direction {dir}"),
            value: v,
            rating,
            source: tables::DAMAGE.file.into(),
            provisional: false,
        });
    }
    vec![
        Cell::text(dir),
        Cell::number(final_v),
        Cell::number(peak_v),
        rating_cell(rating),
    ]
}

/// Chart of ι(t) of one direction with the rating thresholds (preceded by a note
/// when ι has no finite value).
fn iota_figure(
    dir: &str,
    pts: &[(f64, f64)],
    colour: usize,
    time_axis: Option<(f64, f64)>,
    settings: &ReportSettings,
) -> String {
    let th = settings.iota;
    let mut html = String::new();
    if !pts.iter().any(|p| p.1.is_finite()) {
        html.push_str(&note(&format!(
            "ι(t), direction {dir}: no finite value — not rated."
        )));
    }
    let mut chart = Chart::new(560, 280, "t (s)", "ι");
    chart.x_range = time_axis;
    chart.series.push(Series::new(
        format!("ι(t), direction {dir}"),
        plot::decimate_min_max(pts, settings.max_points_per_trace),
        colour % 7,
        Mark::Line,
    ));
    chart.ref_lines.push(RefLine {
        at: th.yellow,
        horizontal: true,
        colour: 4,
    });
    chart.ref_lines.push(RefLine {
        at: th.red,
        horizontal: true,
        colour: 1,
    });
    html.push_str(&figure(
        plot::render(&chart),
        &format!("Damage index ι(t), direction {dir}; dashed: yellow (orange) and red (vermillion) thresholds"),
        "",
    ));
    html
}

/// Chart of the natural-frequency ratios ω(t)/ω(0) of one direction (nothing without
/// ratio series).
fn ratio_figure(
    dir: &str,
    ratios: Vec<(String, Vec<(f64, f64)>)>,
    time_axis: Option<(f64, f64)>,
    settings: &ReportSettings,
) -> String {
    if ratios.is_empty() {
        return String::new();
    }
    time_series_figure(
        Chart::new(560, 280, "t (s)", "ω(t)/ω(0)"),
        ratios,
        time_axis,
        settings,
        &format!("Natural-frequency ratios, direction {dir}"),
    )
}
