//! The assessment the page opens with: `assessment/assessment.parquet`'s row (colour,
//! inspection priority, confidence, drivers, damage-state probabilities,
//! each indicator's value and verdict, assumptions) and the apparent
//! frequency through the event (`frequency_track/frequency_track.parquet`).  Nothing is
//! recomputed: the `assess` stage decided; the page shows it.

use std::path::Path;

use serde::Serialize;

use super::{figure, listed, Loaded};
use crate::report::html::{escape, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::Table;
use crate::report::{format_number, ReportSettings};
use crate::vocab::tables::{assessment as a, frequency_track as ft, ASSESSMENT};

/// One indicator as tabled.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IndicatorView {
    pub indicator: &'static str,
    pub value: Option<f64>,
    pub state: Option<String>,
    pub verdict: String,
}

/// `assessment/assessment.parquet`'s row, as the page and the `--json` summary show it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AssessmentView {
    /// `GREEN`, `YELLOW`, `ORANGE`, `RED` or `NOT RATED`.
    pub rating: String,
    pub priority: Option<String>,
    pub damage_state: Option<String>,
    pub confidence: String,
    pub provisional: bool,
    pub drivers: Vec<String>,
    pub not_rated_reason: Option<String>,
    pub building_type: Option<String>,
    pub design_level: Option<String>,
    pub building_type_source: String,
    /// P(none), P(slight), P(moderate), P(extensive), P(complete).
    pub probabilities: Option<[f64; 5]>,
    pub ems98_grade: Option<String>,
    pub indicators: Vec<IndicatorView>,
    pub frequency_before_hz: Option<f64>,
    pub frequency_min_during_hz: Option<f64>,
    pub frequency_after_hz: Option<f64>,
    pub assumptions: Vec<String>,
}

fn text(t: &Table, c: &str) -> Option<String> {
    t.key(c, 0).filter(|s| !s.is_empty())
}
fn num(t: &Table, c: &str) -> Option<f64> {
    t.number(c)?.first().copied().flatten()
}
fn list(t: &Table, c: &str) -> Vec<String> {
    t.text_list(c)
        .and_then(|l| l.first().cloned().flatten())
        .unwrap_or_default()
}

impl AssessmentView {
    /// The view of a loaded `assessment/assessment.parquet` (its first row).
    pub fn of(t: &Table) -> Option<AssessmentView> {
        if t.rows == 0 {
            return None;
        }
        let probabilities = [
            a::P_NONE,
            a::P_SLIGHT,
            a::P_MODERATE,
            a::P_EXTENSIVE,
            a::P_COMPLETE,
        ]
        .map(|c| num(t, c.name));
        let indicator =
            |name: &'static str, value: &str, state: &str, verdict: &str| IndicatorView {
                indicator: name,
                value: num(t, value),
                state: text(t, state),
                verdict: text(t, verdict).unwrap_or_default(),
            };
        Some(AssessmentView {
            rating: text(t, a::RATING.name).unwrap_or_else(|| "NOT RATED".into()),
            priority: text(t, a::PRIORITY.name),
            damage_state: text(t, a::DAMAGE_STATE.name),
            confidence: text(t, a::CONFIDENCE.name).unwrap_or_default(),
            provisional: t
                .boolean(a::PROVISIONAL.name)
                .and_then(|b| b.first().copied().flatten())
                .unwrap_or(false),
            drivers: list(t, a::DRIVERS.name),
            not_rated_reason: text(t, a::NOT_RATED_REASON.name),
            building_type: text(t, a::BUILDING_TYPE.name),
            design_level: text(t, a::DESIGN_LEVEL.name),
            building_type_source: text(t, a::BUILDING_TYPE_SOURCE.name).unwrap_or_default(),
            probabilities: probabilities
                .iter()
                .all(Option::is_some)
                .then(|| probabilities.map(|p| p.unwrap_or(f64::NAN))),
            ems98_grade: text(t, a::EMS98_GRADE.name),
            indicators: [
                indicator(
                    "peak drift",
                    a::DRIFT_RATIO.name,
                    a::DRIFT_STATE.name,
                    a::DRIFT_VERDICT.name,
                ),
                indicator(
                    "apparent frequency (permanent drop)",
                    a::FREQUENCY_DROP_PERMANENT.name,
                    a::FREQUENCY_STATE.name,
                    a::FREQUENCY_VERDICT.name,
                ),
                indicator(
                    "hysteresis (final ι)",
                    a::IOTA_FINAL.name,
                    a::HYSTERESIS_STATE.name,
                    a::HYSTERESIS_VERDICT.name,
                ),
                indicator(
                    "residual drift",
                    a::RESIDUAL_DRIFT_RATIO.name,
                    a::RESIDUAL_STATE.name,
                    a::RESIDUAL_VERDICT.name,
                ),
            ]
            .into_iter()
            // The change test only when the run had a reference.
            .chain(text(t, a::CHANGE_TEST_VERDICT.name).map(|_| {
                indicator(
                    "subspace change test (χ² / threshold)",
                    a::CHANGE_TEST_RATIO.name,
                    a::CHANGE_TEST_STATE.name,
                    a::CHANGE_TEST_VERDICT.name,
                )
            }))
            .collect(),
            frequency_before_hz: num(t, a::FREQUENCY_BEFORE_HZ.name),
            frequency_min_during_hz: num(t, a::FREQUENCY_MIN_DURING_HZ.name),
            frequency_after_hz: num(t, a::FREQUENCY_AFTER_HZ.name),
            assumptions: list(t, a::ASSUMPTIONS.name),
        })
    }
}

/// The assessment of a run directory, when its run wrote one (listed by the
/// run manifest) and it reads.
pub fn read_assessment(dir: &Path) -> Option<AssessmentView> {
    if !listed(dir, ASSESSMENT.file) {
        return None;
    }
    let t = crate::report::table::load(&dir.join(ASSESSMENT.file), None).ok()?;
    AssessmentView::of(&t)
}

fn class_of(rating: &str) -> &'static str {
    match rating {
        "GREEN" => "r-green",
        "YELLOW" => "r-yellow",
        "ORANGE" => "r-orange",
        "RED" => "r-red",
        _ => "r-none",
    }
}

fn symbol_of(rating: &str) -> &'static str {
    match rating {
        "GREEN" => "✓",
        "YELLOW" => "!",
        "ORANGE" => "!!",
        "RED" => "✕",
        _ => "–",
    }
}

/// A badge: colour, symbol and text (never colour alone).
pub fn badge(rating: &str) -> String {
    format!(
        "<span class=\"badge {}\">{} {}</span>",
        class_of(rating),
        symbol_of(rating),
        escape(rating)
    )
}

/// The opening box, probabilities, indicators, track and assumptions.
pub(super) fn assessment_html(
    v: &AssessmentView,
    track: &Loaded,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let meaning = match v.rating.as_str() {
        "GREEN" => crate::assessment::Colour::Green.meaning(),
        "YELLOW" => crate::assessment::Colour::Yellow.meaning(),
        "ORANGE" => crate::assessment::Colour::Orange.meaning(),
        "RED" => crate::assessment::Colour::Red.meaning(),
        _ => "no indicator could be rated",
    };
    let drivers = if v.drivers.is_empty() {
        String::new()
    } else {
        format!(
            "<p>Driven by: {}.</p>",
            v.drivers
                .iter()
                .map(|d| escape(d))
                .collect::<Vec<_>>()
                .join("; ")
        )
    };
    let provisional = if v.provisional {
        "<p id=\"rating-provisional\"><b>PROVISIONAL</b>: an indicator behind the rating rests on an assumption (listed below).</p>"
    } else {
        ""
    };
    let reason = v
        .not_rated_reason
        .as_deref()
        .map(|r| format!("<p>{}</p>", escape(r)))
        .unwrap_or_default();
    body.push_str(&format!(
        "<div class=\"rating-box {cls}\" id=\"overall-rating\"><p class=\"big\">{badge}{prov}</p>\
         <p>Inspection priority: <b>{priority}</b>; damage state: <b>{state}</b>; confidence: {confidence}.</p>\
         <p>{meaning}.</p>{drivers}{provisional}{reason}</div>",
        cls = class_of(&v.rating),
        badge = badge(&v.rating),
        prov = if v.provisional { " (provisional)" } else { "" },
        priority = escape(v.priority.as_deref().unwrap_or("—")),
        state = escape(v.damage_state.as_deref().unwrap_or("—")),
        confidence = escape(&v.confidence),
        meaning = escape(meaning),
    ));
    // Damage-state probabilities from the drift fragility.
    body.push_str("<h3>Damage-state probabilities (drift fragility)</h3>");
    match v.probabilities {
        Some(p) => {
            let headers = [
                "none",
                "slight",
                "moderate",
                "extensive",
                "complete",
                "EMS-98 grade",
                "fragility",
            ]
            .map(String::from);
            let mut row: Vec<Cell> = p.iter().map(|x| Cell::text(&format!("{x:.3}"))).collect();
            row.push(Cell::text(v.ems98_grade.as_deref().unwrap_or("—")));
            row.push(Cell::text(&format!(
                "HAZUS {} {} code ({})",
                v.building_type.as_deref().unwrap_or("?"),
                v.design_level.as_deref().unwrap_or("?"),
                v.building_type_source
            )));
            body.push_str(&table(Some("damage-probabilities"), &headers, &[row]));
        }
        None => body.push_str(&note(&format!(
            "No probabilities: {}",
            v.indicators
                .first()
                .map(|i| i.verdict.as_str())
                .unwrap_or("no drift indicator")
        ))),
    }
    // Every indicator with its own verdict.
    body.push_str("<h3>Indicators</h3>");
    let rows: Vec<Vec<Cell>> = v
        .indicators
        .iter()
        .map(|i| {
            vec![
                Cell::text(i.indicator),
                Cell::number(i.value),
                Cell::text(i.state.as_deref().unwrap_or("not rated")),
                Cell::text(&i.verdict),
            ]
        })
        .collect();
    body.push_str(&table(
        Some("indicators-table"),
        &["indicator", "value", "state", "verdict"].map(String::from),
        &rows,
    ));
    body.push_str(&track_figure(track, v, settings));
    if !v.assumptions.is_empty() {
        body.push_str("<h3>Assumptions</h3>");
        body.push_str(&format!(
            "<ul id=\"assessment-assumptions\">{}</ul>",
            v.assumptions
                .iter()
                .map(|s| format!("<li>{}</li>", escape(s)))
                .collect::<String>()
        ));
    }
    body.push_str(&note(
        "Colour rules: a damage state reached by two or more independent indicators gives its colour (none GREEN, slight YELLOW, moderate ORANGE, extensive or complete RED); one indicator alone gives YELLOW (inspect). Thresholds and their sources: docs/assessment.md.",
    ));
    body
}

/// The apparent frequency per direction through the event, with the
/// before / after levels of the driving direction.
fn track_figure(track: &Loaded, v: &AssessmentView, settings: &ReportSettings) -> String {
    let Loaded::Ok(t) = track else {
        return note("No apparent-frequency track (not computed in this run).");
    };
    let (Some(time), Some(freq)) = (t.number(ft::TIME_S.name), t.number(ft::FREQUENCY_HZ.name))
    else {
        return note("The apparent-frequency track lacks its times or frequencies: not drawn.");
    };
    let mut chart = Chart::new(640, 280, "t (s)", "apparent frequency (Hz)");
    let truth = t.number(ft::TRUE_FREQUENCY_HZ.name);
    for (i, (keys, rows)) in t.groups(&[ft::DIRECTION.name]).into_iter().enumerate() {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|&r| Some((time[r]?, freq[r]?)))
            .collect();
        if pts.is_empty() {
            continue;
        }
        chart.series.push(Series::new(
            format!("direction {}", keys.join(" ")),
            plot::decimate_curve(&pts, settings.max_points_per_trace),
            i % 7,
            Mark::LinePoints,
        ));
        // A synthetic event's truth (where the frame is linear over the window).
        let true_pts: Vec<(f64, f64)> = truth
            .map(|tr| {
                rows.iter()
                    .filter_map(|&r| Some((time[r]?, tr[r]?)))
                    .collect()
            })
            .unwrap_or_default();
        if !true_pts.is_empty() {
            chart.series.push(Series::new(
                format!("direction {}: true tangent f₁ (synthetic)", keys.join(" ")),
                true_pts,
                i % 7,
                Mark::HollowCircle,
            ));
        }
    }
    if chart.series.is_empty() {
        return note("The apparent-frequency track holds no estimate.");
    }
    for (at, colour) in [(v.frequency_before_hz, 2), (v.frequency_after_hz, 1)] {
        if let Some(at) = at {
            chart.ref_lines.push(RefLine {
                at,
                horizontal: true,
                colour,
            });
        }
    }
    let legend = plot::legend(&chart.series);
    figure(
        plot::render(&chart),
        &format!(
            "Apparent fundamental frequency through the event (moving windows); dashed: before ({} Hz) and after ({} Hz) the strong shaking",
            v.frequency_before_hz.map(format_number).unwrap_or("—".into()),
            v.frequency_after_hz.map(format_number).unwrap_or("—".into())
        ),
        &legend,
    )
}
