//! Section 4, response spectra (spectra.parquet), one chart per direction.

use std::collections::BTreeMap;
use std::path::Path;

use super::{channel_info, figure, load, require, rows_points, Loaded};
use crate::report::html::column_notes;
use crate::report::plot::{self, Chart, Mark, Series};

pub(super) fn spectra_section(dir: &Path, channels: &Loaded) -> String {
    let mut body = String::new();
    let loaded = load(dir, "spectra.parquet", None);
    let Some(t) = require(&loaded, "spectra.parquet", &mut body) else {
        return body;
    };
    body.push_str(&column_notes(
        t,
        &[
            "channel_id",
            "damping",
            "period_s",
            "sd_m",
            "psv_m_s",
            "psa_m_s2",
            "sa_abs_m_s2",
        ],
    ));
    if !t.has("period_s") || !t.has("psa_m_s2") {
        return body;
    }
    let info = channel_info(channels);
    let dampings: Vec<String> = t
        .groups(&["damping"])
        .into_iter()
        .map(|(k, _)| k.join(""))
        .collect();
    // One chart per direction so curves of one direction compare directly.
    let mut by_dir: BTreeMap<String, Vec<(String, Vec<usize>)>> = BTreeMap::new();
    for (key, rows) in t.groups(&["channel_id"]) {
        let id = key.join("");
        let dir = info
            .get(&id)
            .and_then(|(d, _)| d.clone())
            .unwrap_or_else(|| "unknown direction".into());
        by_dir.entry(dir).or_default().push((id, rows));
    }
    body.push_str("<div class=\"grid2\">");
    for (dir, list) in by_dir {
        let mut chart = Chart::new(560, 320, "period T (s)", "PSA (m/s²)");
        chart.log_x = true;
        for (i, (id, rows)) in list.iter().enumerate() {
            // T = 0 (the PGA row) has no place on a log axis.
            let pts: Vec<(f64, f64)> = rows_points(t, rows, "period_s", "psa_m_s2")
                .into_iter()
                .filter(|p| p.0 > 0.0)
                .collect();
            chart
                .series
                .push(Series::new(id.clone(), pts, i, Mark::Line));
        }
        let legend = plot::legend(&chart.series);
        body.push_str(&figure(
            plot::render(&chart),
            &format!(
                "Pseudo-acceleration response spectra, direction {dir}, damping {}",
                dampings.join(", ")
            ),
            &legend,
        ));
    }
    body.push_str("</div>");
    body
}
