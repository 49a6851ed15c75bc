//! Section 5, acceleration time histories (samples/samples.parquet) as small multiples.
//!
//! samples/samples.parquet holds every sample of every channel (46 M rows for 64
//! channels × 1 h at 200 Hz): it is gone through a batch of rows at a time,
//! never loaded whole.  A trace's points are gathered while its rows last and
//! decimated when they end (our files keep a channel's rows together); a
//! file whose traces are interleaved is read again — counting each trace's
//! points, then decimating them as they come.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

use arrow_array::cast::AsArray;
use arrow_array::{Array, ArrayRef, RecordBatch};
use arrow_schema::DataType;

use super::layout::place_text;
use super::{channel_info, figure, listed, not_loaded, require, Loaded, Outputs};
use crate::report::format_number;
use crate::report::html::{natural_cmp, note};
use crate::report::plot::{self, Chart, Mark, MinMaxDecimator, Series};
use crate::report::table::{self, Column};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, channels, samples};

/// Rows per batch read.
const BATCH_ROWS: usize = 1 << 16;

/// A batch's trace keys (channel ids): strings read in place, any other
/// kind through the report's display conversion.
enum Keys<'a> {
    Utf8(&'a arrow_array::StringArray),
    Other(Column),
}

impl Keys<'_> {
    fn of(array: &ArrayRef) -> Keys<'_> {
        match array.data_type() {
            DataType::Utf8 => Keys::Utf8(array.as_string::<i32>()),
            _ => Keys::Other(table::convert(array)),
        }
    }
    /// The key of `row`, as `Table::groups` makes it.
    fn get(&self, row: usize) -> Cow<'_, str> {
        match self {
            Keys::Utf8(a) if a.is_valid(row) => Cow::Borrowed(a.value(row)),
            Keys::Utf8(_) => Cow::Borrowed("—"),
            Keys::Other(c) => Cow::Owned(table::column_key(c, row).unwrap_or_else(|| "—".into())),
        }
    }
}

/// Calls `each(trace, point)` for every row of samples/samples.parquet, the point
/// when the row holds both a time and an acceleration; traces numbered in
/// order of first appearance.
fn for_each_row(
    path: &Path,
    ids: &mut Vec<String>,
    mut each: impl FnMut(usize, Option<(f64, f64)>),
) -> crate::error::Result<()> {
    let cols = [
        samples::CHANNEL_ID.name,
        samples::T_S.name,
        samples::ACC_M_S2.name,
    ];
    let mut index: BTreeMap<String, usize> = ids.iter().cloned().zip(0..).collect();
    let mut last: Option<(String, usize)> = None;
    table::for_each_batch(path, Some(&cols), BATCH_ROWS, |batch: &RecordBatch| {
        let column = |name: &str| batch.column_by_name(name);
        let (Some(id), Some(t), Some(a)) = (column(cols[0]), column(cols[1]), column(cols[2]))
        else {
            return Ok(());
        };
        let keys = Keys::of(id);
        // Columns of another kind give no points (their traces stay empty).
        let (t, a) = (
            table::number_values(t).unwrap_or_default(),
            table::number_values(a).unwrap_or_default(),
        );
        for row in 0..batch.num_rows() {
            let key = keys.get(row);
            let trace = match &last {
                Some((k, g)) if *k == key => *g,
                _ => {
                    let g = match index.get(key.as_ref()) {
                        Some(&g) => g,
                        None => {
                            ids.push(key.to_string());
                            index.insert(key.to_string(), ids.len() - 1);
                            ids.len() - 1
                        }
                    };
                    last = Some((key.into_owned(), g));
                    g
                }
            };
            match (t.get(row), a.get(row)) {
                (Some(&Some(x)), Some(&Some(y))) => each(trace, Some((x, y))),
                _ => each(trace, None),
            }
        }
        Ok(())
    })
}

pub(super) fn time_history_section(
    dir: &Path,
    o: &Outputs,
    event: &Result<serde_json::Value, String>,
    settings: &ReportSettings,
) -> String {
    let channels = &o.channels;
    let mut body = String::new();
    let path = dir.join(tables::SAMPLES.file);
    let only = [
        samples::CHANNEL_ID.name,
        samples::T_S.name,
        samples::ACC_M_S2.name,
    ];
    let loaded = if !listed(dir, tables::SAMPLES.file) {
        not_loaded(dir, tables::SAMPLES.file)
    } else {
        match table::load_head(&path, Some(&only)) {
            Ok(t) => Loaded::Ok(Box::new(t)),
            Err(e) => Loaded::Unreadable(e.to_string()),
        }
    };
    let Some(t) = require(&loaded, &tables::SAMPLES, &mut body) else {
        return body;
    };
    let missing = t.missing(&[
        samples::CHANNEL_ID.name,
        samples::T_S.name,
        samples::ACC_M_S2.name,
    ]);
    if !missing.is_empty() {
        body.push_str(&note(&format!(
            "The conditioned records lack column(s) the plots need: {}.",
            missing.join(", ")
        )));
        return body;
    }
    let info = channel_info(channels);
    let pga: BTreeMap<String, f64> = match channels {
        Loaded::Ok(c) => (0..c.rows)
            .filter_map(|r| {
                Some((
                    c.key(channels::CHANNEL_ID.name, r)?,
                    c.number(channels::PGA_M_S2.name)?
                        .get(r)
                        .copied()
                        .flatten()?,
                ))
            })
            .collect(),
        _ => BTreeMap::new(),
    };
    let mut traces = match decimated_traces(&path, settings.max_points_per_trace) {
        Ok(t) => t,
        Err(e) => {
            crate::report::html::diagnostic(&format!(
                "{}: not read for the plots: {e}",
                tables::SAMPLES.file
            ));
            body.push_str(&note(
                "The conditioned records could not be read for the plots (appendix, table checks).",
            ));
            return body;
        }
    };
    // Natural order of the channel ids (…02 before …10), as the channel table.
    traces.sort_by(|a, b| natural_cmp(&a.0, &b.0));
    let storeys = event.as_ref().ok().and_then(super::layout::storeys);
    let places: BTreeMap<String, String> = match channels {
        Loaded::Ok(c) => (0..c.rows)
            .filter_map(|r| {
                Some((
                    c.key(channels::CHANNEL_ID.name, r)?,
                    c.key(channels::LOCATION_TEXT.name, r)?,
                ))
            })
            .collect(),
        _ => BTreeMap::new(),
    };
    // Common symmetric y-axis so amplitudes compare across the multiples.
    let peak = traces
        .iter()
        .flat_map(|(_, p)| p.iter().map(|x| x.1.abs()))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let y = if peak > 0.0 { 1.05 * peak } else { 1.0 };
    body.push_str(&note(&format!(
        "Conditioned acceleration, common vertical scale; time from each record's first sample (every time axis of this page starts there). Traces drawn with at most {} points (min–max decimation keeps the peaks); PGA values from the channel table.",
        settings.max_points_per_trace
    )));
    body.push_str("<div class=\"multiples\">");
    for (i, (id, pts)) in traces.into_iter().enumerate() {
        let mut chart = Chart::new(440, 170, "t (s)", "a (m/s²)");
        chart.y_range = Some((-y, y));
        chart.x_range = o.time_axis;
        chart
            .series
            .push(Series::new(id.clone(), pts, i % 7, Mark::Line));
        let (dir, level) = info.get(&id).cloned().unwrap_or((None, None));
        let level = level.and_then(|l| l.parse::<i32>().ok());
        let caption = format!(
            "{id} — {}, {}{}",
            place_text(level, places.get(&id).map(String::as_str), storeys),
            dir.map(|d| format!("direction {}", crate::report::html::direction_text(&d)))
                .unwrap_or_else(|| "direction unknown".into()),
            pga.get(&id)
                .map(|p| format!(", PGA {} m/s²", format_number(*p)))
                .unwrap_or_default()
        );
        body.push_str(&figure(plot::render(&chart), &caption, ""));
    }
    body.push_str("</div>");
    body
}

/// Each trace of samples/samples.parquet (by channel id, in order of first
/// appearance) decimated to at most `max_points` (see the module doc).
fn decimated_traces(
    path: &Path,
    max_points: usize,
) -> crate::error::Result<Vec<(String, Vec<(f64, f64)>)>> {
    let finish = |points: Vec<(f64, f64)>| plot::decimate_min_max(&points, max_points);
    // One pass: the trace being read, and those finished.
    let mut ids: Vec<String> = Vec::new();
    let mut finished: Vec<Option<Vec<(f64, f64)>>> = Vec::new();
    let mut current: Option<(usize, Vec<(f64, f64)>)> = None;
    let mut interleaved = false;
    for_each_row(path, &mut ids, |g, point| {
        if interleaved {
            return;
        }
        if current.as_ref().is_none_or(|(c, _)| *c != g) {
            if let Some((c, points)) = current.take() {
                finished[c] = Some(finish(points));
            }
            if g < finished.len() {
                interleaved = true; // seen before: its rows are not together
                return;
            }
            finished.resize(g + 1, None);
            current = Some((g, Vec::new()));
        }
        if let (Some((_, points)), Some(p)) = (current.as_mut(), point) {
            points.push(p);
        }
    })?;
    if !interleaved {
        if let Some((c, points)) = current.take() {
            finished[c] = Some(finish(points));
        }
        return Ok(ids
            .into_iter()
            .zip(finished)
            .map(|(k, d)| (k, d.unwrap_or_default()))
            .collect());
    }
    // Interleaved traces: points per trace, then each decimated as they come.
    let mut ids: Vec<String> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    for_each_row(path, &mut ids, |g, point| {
        if g >= counts.len() {
            counts.resize(g + 1, 0);
        }
        counts[g] += usize::from(point.is_some());
    })?;
    counts.resize(ids.len(), 0);
    let mut decimators: Vec<MinMaxDecimator> = counts
        .iter()
        .map(|&n| MinMaxDecimator::new(n, max_points))
        .collect();
    for_each_row(path, &mut ids, |g, point| {
        if let (Some(d), Some(p)) = (decimators.get_mut(g), point) {
            d.push(p);
        }
    })?;
    Ok(ids
        .into_iter()
        .zip(decimators)
        .map(|(k, d)| (k, d.finish()))
        .collect())
}

/// Conditioned displacement (`disp_m`) of the channels `ids` of
/// samples/samples.parquet, as (t, u) in time order per channel, only the samples
/// with t in `t_range` (inclusive): what the loops draw their drift from.
/// Gone through a batch at a time, as the traces are.
pub(super) fn displacements(
    path: &Path,
    ids: &std::collections::BTreeSet<String>,
    t_range: (f64, f64),
) -> crate::error::Result<BTreeMap<String, Vec<(f64, f64)>>> {
    let cols = [
        samples::CHANNEL_ID.name,
        samples::T_S.name,
        samples::DISP_M.name,
    ];
    let mut out: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    table::for_each_batch(path, Some(&cols), BATCH_ROWS, |batch: &RecordBatch| {
        let column = |name: &str| batch.column_by_name(name);
        let (Some(id), Some(t), Some(u)) = (column(cols[0]), column(cols[1]), column(cols[2]))
        else {
            return Ok(());
        };
        let keys = Keys::of(id);
        let (t, u) = (
            table::number_values(t).unwrap_or_default(),
            table::number_values(u).unwrap_or_default(),
        );
        for row in 0..batch.num_rows() {
            let key = keys.get(row);
            if !ids.contains(key.as_ref()) {
                continue;
            }
            if let (Some(&Some(x)), Some(&Some(y))) = (t.get(row), u.get(row)) {
                if x >= t_range.0 && x <= t_range.1 {
                    out.entry(key.into_owned()).or_default().push((x, y));
                }
            }
        }
        Ok(())
    })?;
    for v in out.values_mut() {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    Ok(out)
}
