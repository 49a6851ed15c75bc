//! Force–drift loops (hysteresis_fit/hysteresis_fit.parquet): the measured loop of every
//! storey or segment — also where the model is not identified — with the
//! model's on top where it is, drawn as curves (decimated in time order,
//! `plot::decimate_curve`).
//!
//! One drift on the page: the loops are drawn against the drift the drift
//! table reports — the relative displacement of the storey's two records of
//! drift/drift.parquet (`lower_channel`, `upper_channel`) after the condition
//! stage's band-pass, read from samples/samples.parquet at the loop's times — so a
//! loop's largest drawn |drift| is the table's peak drift (within the
//! identification window, which holds the strong motion).  The Bouc-Wen
//! identification integrates the records as recorded (no band-pass); where
//! its drift differs from the band-passed one the loop table says by how
//! much.  Only where the band-passed drift cannot be formed (no conditioned
//! displacement of the two records) is a loop drawn with the
//! identification's own drift, and the table says so.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::drift::{residual, residual_text, Residual};
use super::{figure_with, rows_points, Loaded};
use crate::report::format_number;
use crate::report::html::{column_notes, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{drift, hysteresis_fit};

/// Share of the record (its end) over which a loop's end offset is averaged.
pub const END_WINDOW: f64 = 0.05;

/// Share of the data range left free on each side of a loop's axes.
const LOOP_PAD: f64 = 0.08;

/// Ratio of the identification's drift peak to the band-passed one beyond
/// which the loop table states the difference in words.
const STATED_DIFFERENCE: f64 = 1.2;

/// Peak |drift| and the mean drift over the last [`END_WINDOW`] of the
/// samples (in time order) of one loop, m.
pub fn peak_and_end(drift: &[f64]) -> Option<(f64, f64)> {
    if drift.is_empty() {
        return None;
    }
    let peak = drift.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let tail = ((drift.len() as f64 * END_WINDOW).ceil() as usize).clamp(1, drift.len());
    let end = &drift[drift.len() - tail..];
    Some((peak, end.iter().sum::<f64>() / end.len() as f64))
}

/// Lower and upper level of a segment label: `L0–L1` (en dash) or `L0-L1`.
pub fn segment_levels(label: &str) -> Option<(i32, i32)> {
    let s = label.trim().replace('–', "-");
    let (a, b) = s.split_once("-L")?;
    Some((
        a.trim_start_matches('L').trim().parse().ok()?,
        b.trim().parse().ok()?,
    ))
}

/// The drift table's row of one storey or segment: its records, height,
/// peak drift ratio and residual drift.
struct DriftRow {
    lower_channel: String,
    upper_channel: String,
    height_m: f64,
    peak_ratio: f64,
    residual: Option<Residual>,
}

/// drift/drift.parquet's measured and segment rows per (direction, lower, upper).
fn drift_rows(drift_table: &Loaded) -> BTreeMap<(String, i32, i32), DriftRow> {
    let mut out = BTreeMap::new();
    let Loaded::Ok(t) = drift_table else {
        return out;
    };
    let num = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    for r in 0..t.rows {
        if t.key(drift::KIND.name, r).as_deref() == Some("estimate") {
            continue;
        }
        let (Some(dir), Some(upper)) = (
            t.key(drift::DIRECTION.name, r),
            num(drift::UPPER_LEVEL.name, r).or_else(|| num(drift::STOREY.name, r)),
        ) else {
            continue;
        };
        let upper = upper as i32;
        // Tables before `lower_level`: storeys only.
        let lower = num(drift::LOWER_LEVEL.name, r)
            .map(|l| l as i32)
            .unwrap_or(upper - 1);
        let (Some(lc), Some(uc), Some(h), Some(p)) = (
            t.key(drift::LOWER_CHANNEL.name, r),
            t.key(drift::UPPER_CHANNEL.name, r),
            num(drift::STOREY_HEIGHT_M.name, r),
            num(drift::PEAK_DRIFT_RATIO.name, r),
        ) else {
            continue;
        };
        out.insert(
            (dir, lower, upper),
            DriftRow {
                lower_channel: lc,
                upper_channel: uc,
                height_m: h,
                peak_ratio: p,
                residual: residual(t, r),
            },
        );
    }
    out
}

/// The value at time `t` of a series sampled in time order, when a sample
/// lies within half a step of it.
fn at(series: &[(f64, f64)], t: f64) -> Option<f64> {
    let i = series.partition_point(|p| p.0 < t);
    let step = match series {
        [a, b, ..] => (b.0 - a.0).abs(),
        _ => 0.0,
    };
    [i.checked_sub(1), Some(i)]
        .into_iter()
        .flatten()
        .filter_map(|j| series.get(j))
        .filter(|p| (p.0 - t).abs() <= 0.5 * step + 1e-9)
        .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
        .map(|p| p.1)
}

/// The conditioned displacements of the records the loops need, over the
/// loops' time span; empty when samples/samples.parquet is not there or lacks them.
fn conditioned(
    samples: Option<&Path>,
    t: &Table,
    rows: &BTreeMap<(String, i32, i32), DriftRow>,
) -> (BTreeMap<String, Vec<(f64, f64)>>, Option<String>) {
    let Some(path) = samples else {
        return (BTreeMap::new(), Some("conditioned records absent".into()));
    };
    let ids: BTreeSet<String> = rows
        .values()
        .flat_map(|r| [r.lower_channel.clone(), r.upper_channel.clone()])
        .collect();
    let times = t.number(hysteresis_fit::T_S.name).unwrap_or(&[]);
    let (lo, hi) = times
        .iter()
        .flatten()
        .fold((f64::MAX, f64::MIN), |(l, h), v| (l.min(*v), h.max(*v)));
    if ids.is_empty() || lo > hi {
        return (BTreeMap::new(), None);
    }
    match super::time_histories::displacements(path, &ids, (lo - 1.0, hi + 1.0)) {
        Ok(m) => (m, None),
        Err(e) => {
            crate::report::html::diagnostic(&format!(
                "samples/samples.parquet: conditioned displacements for the loops not read: {e}"
            ));
            (
                BTreeMap::new(),
                Some("conditioned records unreadable".into()),
            )
        }
    }
}

/// The residual drift as the loop table shows it: resolved with its value,
/// otherwise "not resolved" without a number.
fn residual_cell(res: Option<&Residual>) -> Cell {
    match res {
        Some(r) if r.resolved() && !r.artefact() => Cell {
            value: Some(r.drift_m),
            class: Some("num"),
            ..Cell::text(&residual_text(r))
        },
        Some(r) if r.artefact() => Cell::text("not resolved (baseline artefact)"),
        Some(_) => Cell::text("not resolved"),
        None => Cell::number(None),
    }
}

pub(super) fn loops_section(
    t: &Table,
    velocity_drift: Option<&str>,
    drift_table: &Loaded,
    samples: Option<&Path>,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let known = [
        hysteresis_fit::DIRECTION.name,
        hysteresis_fit::DOF.name,
        hysteresis_fit::SEGMENT.name,
        hysteresis_fit::T_S.name,
        hysteresis_fit::DRIFT_M.name,
        hysteresis_fit::FORCE_RECORD_N.name,
        hysteresis_fit::FORCE_MODEL_N.name,
        hysteresis_fit::ENERGY_RECORD_J.name,
    ];
    body.push_str(&column_notes(t, &known));
    if !t.has(hysteresis_fit::DRIFT_M.name) || !t.has(hysteresis_fit::FORCE_RECORD_N.name) {
        return body;
    }
    let rows_by_segment = drift_rows(drift_table);
    let (motions, why_not) = conditioned(samples, t, &rows_by_segment);
    body.push_str(&note(&format!(
        "The loops are drawn against the drift of the inter-storey drift section: the relative displacement of the storey's two \
         records after the condition stage's band-pass, at the loop's times — so the largest drift drawn is the drift table's peak. \
         Force: the storey (segment) shear V = Σ of −m (a + ü) over the instrumented levels above, from the records as recorded \
         (Eq. 46, lumped masses). The Bouc-Wen identification integrates the records as recorded, without band-pass (velocity drift \
         control: {}); its drift keeps a permanent offset, and also integrated sensor noise and baseline error — where its peak \
         differs from the band-passed one by more than {:.0} %, the table below says by how much. The model's shear is drawn against \
         the same band-passed drift. Curves keep every reversal: decimated in time order to segments of at most {:.1} % of either \
         axis' data range (unless one sample step is longer) and at most {} points.",
        velocity_drift.unwrap_or("as set in the hysteresis stage"),
        100.0 * (STATED_DIFFERENCE - 1.0),
        100.0 * plot::CURVE_MAX_STEP,
        settings.max_points_per_loop
    )));
    let keys: Vec<&str> = [hysteresis_fit::DIRECTION.name, hysteresis_fit::DOF.name]
        .into_iter()
        .filter(|k| t.has(k))
        .collect();
    let mut figures = String::from("<div class=\"multiples\">");
    let mut rows_html = Vec::new();
    for (key, rows) in t.groups(&keys) {
        let segment = rows
            .first()
            .and_then(|&r| t.key(hysteresis_fit::SEGMENT.name, r))
            .unwrap_or_default();
        let direction = key.first().cloned().unwrap_or_default();
        let levels = segment_levels(&segment);
        let place = match levels {
            Some((a, b)) => format!("{a}–{b}"),
            None => format!("dof {}", key.get(1).cloned().unwrap_or_default()),
        };
        let row = levels.and_then(|(a, b)| rows_by_segment.get(&(direction.clone(), a, b)));
        let times: Vec<Option<f64>> = rows
            .iter()
            .map(|&r| {
                t.number(hysteresis_fit::T_S.name)
                    .and_then(|v| v.get(r).copied().flatten())
            })
            .collect();
        // The band-passed drift at each loop time, when both records have it.
        let band_passed: Option<Vec<Option<f64>>> = row.and_then(|d| {
            let (l, u) = (
                motions.get(&d.lower_channel)?,
                motions.get(&d.upper_channel)?,
            );
            let v: Vec<Option<f64>> = times
                .iter()
                .map(|t| Some(at(u, (*t)?)? - at(l, (*t)?)?))
                .collect();
            (v.iter().flatten().count() * 2 > v.len()).then_some(v)
        });
        let own: Vec<(f64, f64)> = rows_points(
            t,
            &rows,
            hysteresis_fit::T_S.name,
            hysteresis_fit::DRIFT_M.name,
        );
        let own_peak = peak_and_end(&own.iter().map(|p| p.1).collect::<Vec<_>>()).map(|p| p.0);
        let force = |col: &str| -> Vec<Option<f64>> {
            rows.iter()
                .map(|&r| t.number(col).and_then(|v| v.get(r).copied().flatten()))
                .collect()
        };
        let own_drift = force(hysteresis_fit::DRIFT_M.name);
        let x: &[Option<f64>] = band_passed.as_deref().unwrap_or(&own_drift);
        let curve = |col: &str| -> Vec<(f64, f64)> {
            let pts: Vec<(f64, f64)> = x
                .iter()
                .zip(force(col))
                .filter_map(|(d, f)| Some(((*d)?, f? / 1000.0)))
                .collect();
            plot::decimate_curve(&pts, settings.max_points_per_loop)
        };
        let record = curve(hysteresis_fit::FORCE_RECORD_N.name);
        let model = curve(hysteresis_fit::FORCE_MODEL_N.name);
        let identified = !model.is_empty();
        let drawn_peak = record
            .iter()
            .chain(&model)
            .fold(0.0f64, |m, p| m.max(p.0.abs()));
        let table_peak = row.map(|d| d.peak_ratio * d.height_m);
        let difference = match (band_passed.is_some(), own_peak) {
            (false, _) => format!(
                "drawn with this drift ({}): the band-passed drift of the records could not be formed",
                why_not
                    .clone()
                    .unwrap_or_else(|| "no drift-table row or conditioned displacement for this storey".into())
            ),
            (true, Some(p)) if drawn_peak > 0.0 && p > STATED_DIFFERENCE * drawn_peak => format!(
                "{} m: {:.1} × the band-passed peak — low-frequency drift the band-pass removes (a permanent offset, or integrated noise and baseline error: compare the residual drift)",
                format_number(p),
                p / drawn_peak
            ),
            (true, Some(p)) => format!("{} m: as band-passed", format_number(p)),
            (true, None) => "—".into(),
        };
        rows_html.push(vec![
            Cell::text(&direction),
            Cell::text(&place),
            Cell::number(table_peak),
            Cell::number((drawn_peak > 0.0).then_some(drawn_peak)),
            Cell::text(&difference),
            residual_cell(row.and_then(|d| d.residual.as_ref())),
            Cell::text(if identified {
                "yes"
            } else {
                "no: measured loop only"
            }),
        ]);
        let mut chart = Chart::new(440, 320, "storey drift (m)", "storey shear (kN)");
        chart.x_pad = Some(LOOP_PAD);
        chart.y_pad = LOOP_PAD;
        chart
            .series
            .push(Series::new("measured", record, 0, Mark::Line));
        if identified {
            chart
                .series
                .push(Series::new("model", model, 1, Mark::Dashed));
        }
        let legend = plot::legend(&chart.series);
        let caption = if identified {
            format!("Force–drift loop, direction {direction}, levels {place}: measured and model")
        } else {
            format!(
                "Measured force–drift loop, direction {direction}, levels {place} (model not identified: see the reason above)"
            )
        };
        figures.push_str(&figure_with(
            "class=\"loop\"",
            plot::render(&chart),
            &caption,
            &legend,
        ));
    }
    figures.push_str("</div>");
    let headers: Vec<String> = [
        "direction",
        "levels",
        "peak drift, drift table (m)",
        "largest drift drawn (m)",
        "identification's drift peak (as recorded, no band-pass)",
        "residual drift (baseline-corrected)",
        "model identified",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    body.push_str(&table(Some("loop-drift-table"), &headers, &rows_html));
    body.push_str(&figures);
    body
}
