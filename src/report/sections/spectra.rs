//! Section 4, response spectra (spectra/spectra.parquet), one chart per direction.

use std::collections::BTreeMap;
use std::path::Path;

use super::{channel_info, figure, load, require, rows_points, Loaded};
use crate::report::html::{column_notes, direction_text};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::vocab::tables::{self, spectra};

pub(super) fn spectra_section(dir: &Path, channels: &Loaded) -> String {
    let mut body = String::new();
    let loaded = load(dir, &tables::SPECTRA, None);
    let Some(t) = require(&loaded, &tables::SPECTRA, &mut body) else {
        return body;
    };
    body.push_str(&column_notes(
        t,
        &[
            spectra::CHANNEL_ID.name,
            spectra::DAMPING.name,
            spectra::PERIOD_S.name,
            spectra::SD_M.name,
            spectra::PSV_M_S.name,
            spectra::PSA_M_S2.name,
            spectra::SA_ABS_M_S2.name,
        ],
    ));
    if !t.has(spectra::PERIOD_S.name) || !t.has(spectra::PSA_M_S2.name) {
        return body;
    }
    let info = channel_info(channels);
    let dampings: Vec<String> = t
        .groups(&[spectra::DAMPING.name])
        .into_iter()
        .map(|(k, _)| k.join(""))
        .collect();
    // One chart per direction so curves of one direction compare directly.
    let mut by_dir: BTreeMap<String, Vec<(String, Vec<usize>)>> = BTreeMap::new();
    for (key, rows) in t.groups(&[spectra::CHANNEL_ID.name]) {
        let id = key.join("");
        let dir = info
            .get(&id)
            .and_then(|(d, _)| d.clone())
            .unwrap_or_else(|| "unknown direction".into());
        by_dir.entry(dir).or_default().push((id, rows));
    }
    body.push_str("<div class=\"grid2\">");
    for (dir, mut list) in by_dir {
        // Curves in natural order of the channel ids, as the channel table.
        list.sort_by(|a, b| crate::report::html::natural_cmp(&a.0, &b.0));
        let mut chart = Chart::new(560, 320, "period T (s)", "PSA (m/s²)");
        chart.log_x = true;
        for (i, (id, rows)) in list.iter().enumerate() {
            // T = 0 (the PGA row) has no place on a log axis.
            let pts: Vec<(f64, f64)> =
                rows_points(t, rows, spectra::PERIOD_S.name, spectra::PSA_M_S2.name)
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
                "Pseudo-acceleration response spectra, direction {}, damping {}",
                direction_text(&dir),
                dampings.join(", ")
            ),
            &legend,
        ));
    }
    body.push_str("</div>");
    body
}
