//! Fourier amplitude spectra of each record's signal and pre-event noise
//! windows with the filter corners applied (chosen from their ratio, or the
//! pipeline's when the record has no usable noise window): one chart per
//! channel, channels in their natural order (numbers compared as numbers).

use std::path::Path;

use super::{figure, listed, load, require};
use crate::report::html::{natural_cmp, note};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::Table;
use crate::vocab::tables::{self, fourier};

/// The first value of column `name` over `rows`.
fn first_number(t: &Table, rows: &[usize], name: &str) -> Option<f64> {
    let col = t.number(name)?;
    rows.iter().find_map(|&r| col.get(r).copied().flatten())
}

fn first_text(t: &Table, rows: &[usize], name: &str) -> Option<String> {
    let col = t.text(name)?;
    rows.iter().find_map(|&r| col.get(r).cloned().flatten())
}

/// One channel's chart and the words under it.
fn channel_figure(t: &Table, id: &str, rows: &[usize]) -> String {
    let points = |y: &str| -> Vec<(f64, f64)> {
        super::rows_points(t, rows, fourier::FREQUENCY_HZ.name, y)
            .into_iter()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .collect()
    };
    let signal = points(fourier::SIGNAL_FAS.name);
    let noise = points(fourier::NOISE_FAS.name);
    let high = first_number(t, rows, fourier::HIGH_PASS_HZ.name);
    let low = first_number(t, rows, fourier::LOW_PASS_HZ.name);
    let mut chart = Chart::new(420, 280, "frequency (Hz)", "amplitude density (m/s²/√Hz)");
    chart.log_x = true;
    chart.log_y = true;
    // The corners on the axis even when they lie outside the spectra.
    let xs = signal.iter().map(|p| p.0).chain(high).chain(low);
    let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(l, h), x| (l.min(x), h.max(x)));
    if lo.is_finite() && hi > lo {
        chart.x_range = Some((lo / 1.2, hi * 1.2));
    }
    chart
        .series
        .push(Series::new("signal window", signal, 0, Mark::Line));
    if !noise.is_empty() {
        chart.series.push(Series::new(
            "noise window (before the onset)",
            noise,
            1,
            Mark::Dashed,
        ));
    }
    for at in high.into_iter().chain(low) {
        chart.ref_lines.push(RefLine {
            at,
            horizontal: false,
            colour: 2,
        });
    }
    let mut legend = plot::legend(&chart.series);
    legend.push_str(&format!(
        "<ul class=\"legend\"><li><span class=\"swatch\" style=\"color:{}\">╎</span> filter corners applied</li></ul>",
        plot::css_colour(2)
    ));
    let from_snr = first_text(t, rows, fourier::CORNERS_FROM.name).as_deref() == Some("snr");
    let corners: Vec<String> = [("high-pass", high), ("low-pass", low)]
        .iter()
        .filter_map(|(name, f)| {
            f.map(|f| format!("{name} {}", crate::conditioning::snr::hz_text(f)))
        })
        .collect();
    let caption = format!(
        "Channel {id}: {}{}",
        if corners.is_empty() {
            "no corners recorded".to_string()
        } else {
            corners.join(", ")
        },
        if from_snr {
            " (chosen from the signal-to-noise ratio)"
        } else {
            " (the pipeline's corners: no usable noise window)"
        }
    );
    let mut out = figure(plot::render(&chart), &caption, &legend);
    if let Some(why) = first_text(t, rows, fourier::NOTE.name) {
        // One sentence per corner, each starting with a capital.
        let sentences: Vec<String> = why
            .split("; ")
            .map(|s| {
                let mut c = s.chars();
                c.next()
                    .map(|f| f.to_uppercase().chain(c).collect())
                    .unwrap_or_default()
            })
            .collect();
        out.push_str(&note(&format!("{}.", sentences.join(". "))));
    }
    format!("<div>{out}</div>")
}

pub(super) fn fourier_section(dir: &Path) -> String {
    let mut body = String::new();
    // Conditioned with stated corners: nothing is missing, say so plainly.
    if !listed(dir, tables::FOURIER.file) && listed(dir, tables::SAMPLES.file) {
        body.push_str(&note(
            "The conditioning filtered every record with the corners the pipeline states; it did not choose them per record from the signal-to-noise ratio, so no spectra were kept.",
        ));
        return body;
    }
    let loaded = load(dir, &tables::FOURIER, None);
    let Some(t) = require(&loaded, &tables::FOURIER, &mut body) else {
        return body;
    };
    if !t.has(fourier::FREQUENCY_HZ.name) || !t.has(fourier::SIGNAL_FAS.name) {
        body.push_str(&note(
            "The spectra table has no frequencies or amplitudes to draw.",
        ));
        return body;
    }
    let mut groups = t.groups(&[fourier::CHANNEL_ID.name]);
    groups.sort_by(|a, b| natural_cmp(&a.0.join(""), &b.0.join("")));
    let from_snr = groups
        .iter()
        .filter(|(_, rows)| {
            first_text(t, rows, fourier::CORNERS_FROM.name).as_deref() == Some("snr")
        })
        .count();
    body.push_str(&format!(
        "<p>Smoothed Fourier amplitude spectra of each record's shaking (from its onset to 95 % of its energy) and of the quiet record before the onset, each divided by the square root of its duration so that the two compare as densities; their ratio is the signal-to-noise ratio. The filter's corners were chosen from it for {from_snr} of {} channels: the high-pass where the ratio rises above the threshold, the low-pass where it falls below it, within the bounds the pipeline sets. A record without a long enough quiet start keeps the pipeline's corners.</p>",
        groups.len()
    ));
    body.push_str("<div class=\"multiples\">");
    for (key, rows) in &groups {
        body.push_str(&channel_figure(t, &key.join(""), rows));
    }
    body.push_str("</div>");
    body
}
