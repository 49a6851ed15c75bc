//! The overall rating (first section): the worst of the available criteria,
//! the values that drive it, every criterion with its thresholds and what it
//! rated, and the criteria that could not be used and why.

use super::drift::{notes_of, residual, PEAK_CRITERION, RESIDUAL_CRITERION};
use super::{stage_of, Loaded, Outputs};
use crate::report::format_number;
use crate::report::html::{escape, note, short_number, table, Cell};
use crate::report::{Assessment, Rating, ReportSettings, Thresholds};
use crate::vocab::tables;

/// Why a criterion's file gives no value (None when it does).
fn file_gap(file: &str, loaded: &Loaded) -> Option<String> {
    match loaded {
        Loaded::Ok(t) if t.rows == 0 => Some(super::empty_text(file)),
        Loaded::Ok(_) => None,
        Loaded::Absent(Some(why)) => Some(format!("not applicable: {why}")),
        Loaded::Absent(None) => Some(format!(
            "no {}: stage {} not run",
            super::label_of(file),
            stage_of(file)
        )),
        Loaded::Unreadable(_) => Some(format!("the {} could not be read", super::label_of(file))),
    }
}

/// Why the residual drift gives no rated value, when it gives none.
fn residual_gap(drift: &Loaded) -> String {
    if let Some(gap) = file_gap(tables::DRIFT.file, drift) {
        return gap;
    }
    let Loaded::Ok(t) = drift else {
        return String::new();
    };
    if !t.has(tables::drift::RESIDUAL_DRIFT_M.name) {
        return "the inter-storey drift table has no residual drift (written by an earlier quaketwin: run the pipeline again)"
            .into();
    }
    let values: Vec<_> = (0..t.rows).filter_map(|r| residual(t, r)).collect();
    if values.is_empty() {
        return "no storey or segment has unfiltered records of both levels on a common time base"
            .into();
    }
    let artefacts = values.iter().filter(|v| v.artefact()).count();
    let mut why = Vec::new();
    if artefacts > 0 {
        why.push(format!(
            "{artefacts} an artefact (|D| more than twice the row's own peak drift: a baseline error, never rated)"
        ));
    }
    if artefacts < values.len() {
        why.push(format!(
            "{} not resolved: |D| < 2σ, the estimate does not stand out of the sensor noise that double integration turns into drift",
            values.len() - artefacts
        ));
    }
    format!("no resolved residual drift: {}", why.join("; "))
}

/// Why drift/drift.parquet gives no peak drift to rate.
fn peak_gap(drift: &Loaded) -> String {
    if let Loaded::Ok(t) = drift {
        let notes = notes_of(t);
        if !notes.is_empty() {
            let lead = if t.rows == 0 {
                "no drift could be formed"
            } else {
                "the inter-storey drift table holds no ratable value"
            };
            return format!("{lead}: {}", notes.join("; "));
        }
    }
    file_gap(tables::DRIFT.file, drift)
        .unwrap_or_else(|| "the inter-storey drift table holds no ratable value".into())
}

fn thresholds_text(t: &Thresholds) -> String {
    format!(
        "GREEN < {} ≤ YELLOW < {} ≤ RED",
        short_number(t.yellow),
        short_number(t.red)
    )
}

pub(super) fn rating_section(
    dir: &std::path::Path,
    assessments: &[Assessment],
    o: &Outputs,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let verdict = crate::report::Verdict::of(assessments.to_vec());
    let assessed = super::read_assessment(dir);
    if let Some(view) = &assessed {
        let track = super::load(dir, &tables::FREQUENCY_TRACK, None);
        body.push_str(&super::assessment::assessment_html(view, &track, settings));
        body.push_str("<h3>Screening values by threshold</h3>");
        body.push_str(&note(
            "Each tabled value against fixed screening thresholds (FEMA 356 braced-frame drift limits, ι limits): context for the indicators above, not the rating.",
        ));
    }
    match verdict.rating {
        _ if assessed.is_some() => {}
        None => {
            body.push_str(
                "<div class=\"rating-box r-none\" id=\"overall-rating\"><p class=\"big\">NOT RATED</p><p>No rating criterion is available (see below).</p></div>",
            );
        }
        Some(w) => {
            // The criterion values that reach the worst rating (the largest per criterion).
            let driven: Vec<String> = verdict
                .drivers
                .iter()
                .map(|a| {
                    format!(
                        "{} = {} at {} ({}){}",
                        escape(&a.criterion),
                        format_number(a.value),
                        escape(&a.subject),
                        escape(super::label_of(&a.source)),
                        if a.provisional { ": provisional" } else { "" }
                    )
                })
                .collect();
            let provisional = if verdict.provisional {
                "<p id=\"rating-provisional\"><b>PROVISIONAL</b>: rated on drift ratios over ASSUMED storey heights (no heights stated for the structure); state structure.storey_heights_m, or height_m and storeys, in event.toml.</p>"
            } else {
                ""
            };
            body.push_str(&format!(
                "<div class=\"rating-box {cls}\" id=\"overall-rating\"><p class=\"big\">{badge}{}</p><p>{meaning}.</p><p>Driven by: {}.</p>{provisional}</div>",
                if verdict.provisional { " (provisional)" } else { "" },
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
    // Every criterion: used (what it rated) or missing (why).
    let damage_criterion = format!("damage index ι ({})", settings.iota_statistic.name());
    let criteria = [
        (
            PEAK_CRITERION.to_string(),
            settings.drift,
            tables::DRIFT.file,
            peak_gap(&o.drift),
        ),
        (
            RESIDUAL_CRITERION.to_string(),
            settings.residual_drift,
            tables::DRIFT.file,
            residual_gap(&o.drift),
        ),
        (
            damage_criterion,
            settings.iota,
            tables::DAMAGE.file,
            match &o.damage {
                Loaded::Ok(t) if t.rows == 0 => super::damage::NO_ROWS.to_string(),
                other => file_gap(tables::DAMAGE.file, other)
                    .unwrap_or_else(|| "the damage index holds no ratable value".into()),
            },
        ),
    ];
    let mut rows = Vec::new();
    let mut missing = Vec::new();
    for (criterion, th, file, gap) in &criteria {
        let rated: Vec<&Assessment> = assessments
            .iter()
            .filter(|a| &a.criterion == criterion)
            .collect();
        let worst = rated
            .iter()
            .max_by(|a, b| a.rating.cmp(&b.rating).then(a.value.total_cmp(&b.value)));
        match worst {
            Some(w) => rows.push(vec![
                Cell::text(criterion),
                Cell::text(&thresholds_text(th)),
                Cell::text(super::label_of(file)),
                Cell::text(&rated.len().to_string()),
                Cell::text(&format!("{} at {}", format_number(w.value), w.subject)),
                Cell::raw(w.rating.badge()),
            ]),
            None => missing.push(format!(
                "<li><b>{}</b> ({}): {}</li>",
                escape(criterion),
                escape(&thresholds_text(th)),
                escape(gap)
            )),
        }
    }
    body.push_str("<h3>Criteria used</h3>");
    if rows.is_empty() {
        body.push_str(&note("None."));
    } else {
        body.push_str(&table(
            Some("criteria-table"),
            &[
                "criterion",
                "thresholds",
                "from",
                "values rated",
                "worst value",
                "rating",
            ]
            .map(String::from),
            &rows,
        ));
    }
    body.push_str("<h3>Criteria missing</h3>");
    if missing.is_empty() {
        body.push_str(&note("None: every criterion was rated."));
    } else {
        body.push_str(&format!(
            "<ul id=\"criteria-missing\">{}</ul>",
            missing.join("")
        ));
    }
    if assessed.is_none() {
        body.push_str(&note(
            "Overall rating = worst of the available criteria (no assessment: the pipeline has no `assess` stage). Screening values, to be set per structure type; sources and rationale in docs/report.md.",
        ));
    }
    body
}
