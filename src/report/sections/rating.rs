//! Section 2, overall rating: the worst of the available criteria and what drives it.

use std::collections::BTreeMap;

use super::{stage_of, Loaded};
use crate::report::format_number;
use crate::report::html::{escape, note};
use crate::report::{Assessment, Rating, ReportSettings};
use crate::vocab::tables;

pub(super) fn rating_section(
    assessments: &[Assessment],
    drift: &Loaded,
    damage: &Loaded,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let worst = assessments.iter().map(|a| a.rating).max();
    let mut considered = Vec::new();
    for (file, loaded) in [(tables::DRIFT.file, drift), (tables::DAMAGE.file, damage)] {
        considered.push(match loaded {
            Loaded::Ok(_) if assessments.iter().any(|a| a.source == file) => {
                format!("{file}: rated")
            }
            Loaded::Ok(_) => format!("{file}: present but holds no ratable value"),
            Loaded::Absent(Some(why)) => format!("{file}: not applicable ({why})"),
            Loaded::Absent(None) => format!("{file}: absent (stage {} not run)", stage_of(file)),
            Loaded::Unreadable(_) => format!("{file}: unreadable"),
        });
    }
    match worst {
        None => {
            body.push_str(
                "<div class=\"rating-box r-none\" id=\"overall-rating\"><p class=\"big\">NOT RATED</p><p>No rating criterion is available.</p></div>",
            );
        }
        Some(w) => {
            // The criterion values that reach the worst rating, largest first.
            let mut drivers: Vec<&Assessment> =
                assessments.iter().filter(|a| a.rating == w).collect();
            drivers.sort_by(|a, b| b.value.total_cmp(&a.value));
            let mut by_criterion: BTreeMap<&str, &Assessment> = BTreeMap::new();
            for d in &drivers {
                by_criterion.entry(d.criterion.as_str()).or_insert(d);
            }
            let driven: Vec<String> = by_criterion
                .values()
                .map(|a| {
                    format!(
                        "{} = {} at {} ({})",
                        escape(&a.criterion),
                        format_number(a.value),
                        escape(&a.subject),
                        escape(&a.source)
                    )
                })
                .collect();
            body.push_str(&format!(
                "<div class=\"rating-box {cls}\" id=\"overall-rating\"><p class=\"big\">{badge}</p><p>{meaning}.</p><p>Driven by: {}.</p></div>",
                driven.join("; "),
                cls = match w {
                    Rating::Green => "r-green",
                    Rating::Yellow => "r-yellow",
                    Rating::Red => "r-red",
                },
                badge = w.badge(),
                meaning = escape(w.meaning()),
            ));
        }
    }
    body.push_str("<ul>");
    for c in considered {
        body.push_str(&format!("<li>{}</li>", escape(&c)));
    }
    body.push_str("</ul>");
    body.push_str(&note(&format!(
        "Overall rating = worst of the available criteria. Thresholds: drift ratio GREEN < {} ≤ YELLOW < {} ≤ RED; damage index ι ({} value) GREEN < {} ≤ YELLOW < {} ≤ RED. Screening values, see docs/report.md.",
        format_number(settings.drift.yellow),
        format_number(settings.drift.red),
        settings.iota_statistic.name(),
        format_number(settings.iota.yellow),
        format_number(settings.iota.red),
    )));
    body
}
