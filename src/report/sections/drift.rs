//! Inter-storey drift (drift/drift.parquet): peak drift ratio from the band-passed
//! displacements and residual drift from the unfiltered records, their
//! ratings and the profile chart.

use super::{figure, present_columns, rating_cell, require, rows_points, Loaded};
use crate::report::format_number;
use crate::report::html::{column_notes, escape, note, short_number, table, Cell};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::Table;
use crate::report::{Assessment, ReportSettings};
use crate::vocab::tables::{self, drift};

/// Criterion names, as the rating section lists them.
pub(super) const PEAK_CRITERION: &str = "peak inter-storey drift ratio";
pub(super) const RESIDUAL_CRITERION: &str = "residual inter-storey drift ratio";

/// The residual drift of one row: value, σ and ratio, when tabled.
#[derive(Debug, Clone)]
pub(super) struct Residual {
    pub drift_m: f64,
    pub std_m: Option<f64>,
    pub ratio: Option<f64>,
    /// `residual_status` (absent in tables of earlier versions).
    pub status: Option<String>,
}

impl Residual {
    /// Rated: the tabled `residual_status` is `resolved`; a table written
    /// before that column: |D| ≥ 2σ (no σ tabled: not resolved).
    pub fn resolved(&self) -> bool {
        match &self.status {
            Some(status) => status == "resolved",
            None => self
                .std_m
                .is_some_and(|s| s.is_finite() && self.drift_m.abs() >= 2.0 * s),
        }
    }
    /// |D| exceeds the row's own peak drift (`residual_status` artefact).
    pub fn artefact(&self) -> bool {
        self.status.as_deref() == Some("artefact")
    }
    /// Why an unrated residual is not rated.
    pub fn why_not_rated(&self) -> &'static str {
        if self.artefact() {
            "artefact: |D| > 2 × the peak drift (not rated)"
        } else {
            "not resolved (|D| < 2σ)"
        }
    }
}

/// The residual drift of row `r` of drift/drift.parquet.
pub(super) fn residual(t: &Table, r: usize) -> Option<Residual> {
    let num = |c: &str| t.number(c).and_then(|v| v.get(r).copied().flatten());
    Some(Residual {
        drift_m: num(drift::RESIDUAL_DRIFT_M.name)?,
        std_m: num(drift::RESIDUAL_DRIFT_STD_M.name),
        ratio: num(drift::RESIDUAL_DRIFT_RATIO.name),
        status: t.key(drift::RESIDUAL_STATUS.name, r),
    })
}

/// What row `r` is: its kind (`measured` for a table written before the
/// `kind` column) and whether its height was assumed.
pub(super) struct RowKind {
    pub kind: String,
    pub assumed_height: Option<f64>,
    /// The segment reaches a roof whose level was assumed: its height is
    /// unknown, the row is shown and not rated.
    pub roof_level_assumed: bool,
}

impl RowKind {
    pub fn of(t: &Table, r: usize) -> RowKind {
        let source = t.key(drift::HEIGHT_SOURCE.name, r);
        let assumed = source.as_deref() == Some("assumed");
        RowKind {
            roof_level_assumed: source.as_deref() == Some("unknown: roof level assumed"),
            kind: t
                .key(drift::KIND.name, r)
                .unwrap_or_else(|| "measured".into()),
            assumed_height: assumed
                .then(|| {
                    t.number(drift::STOREY_HEIGHT_M.name)
                        .and_then(|v| v.get(r).copied().flatten())
                })
                .flatten(),
        }
    }
    /// Estimates, and segments up to an assumed roof level, are shown,
    /// never rated.
    pub fn rated(&self) -> bool {
        self.kind != "estimate" && !self.roof_level_assumed
    }
}

/// Where row `r` is: "storey 2, direction X" (a measured storey),
/// "levels 0–3, direction X" (a segment), "storey 2 (estimate), direction X";
/// with an assumed height, "(assumed storey height 3.5 m)".
pub(super) fn subject(t: &Table, r: usize) -> String {
    let key = |c: &str| t.key(c, r).unwrap_or_else(|| "?".into());
    let row = RowKind::of(t, r);
    let place = match row.kind.as_str() {
        "segment" => format!(
            "levels {}–{}",
            key(drift::LOWER_LEVEL.name),
            key(drift::UPPER_LEVEL.name)
        ),
        "estimate" => format!("storey {} (estimate)", key(drift::STOREY.name)),
        _ => format!("storey {}", key(drift::STOREY.name)),
    };
    let assumed = match row.assumed_height {
        Some(h) => {
            let storeys = t
                .number(drift::UPPER_LEVEL.name)
                .zip(t.number(drift::LOWER_LEVEL.name))
                .and_then(|(u, l)| {
                    Some(u.get(r).copied().flatten()? - l.get(r).copied().flatten()?)
                })
                .filter(|n| *n > 0.0)
                .unwrap_or(1.0);
            format!(" (assumed storey height {} m)", format_number(h / storeys))
        }
        None => String::new(),
    };
    format!("{place}, direction {}{assumed}", key(drift::DIRECTION.name))
}

/// The notes drift/drift.parquet carries (why drift is missing, heights assumed,
/// records trimmed), as a list; empty when none.
pub(super) fn notes_of(t: &Table) -> Vec<String> {
    t.metadata
        .get(crate::sinks::event_tables::DRIFT_NOTES_KEY)
        .and_then(|s| serde_json::from_str(s).ok())
        .unwrap_or_default()
}

fn notes_html(notes: &[String]) -> String {
    if notes.is_empty() {
        return String::new();
    }
    let items: Vec<String> = notes
        .iter()
        .map(|n| format!("<li>{}</li>", escape(n)))
        .collect();
    format!("<ul id=\"drift-notes\">{}</ul>", items.join(""))
}

/// "−12.3 ± 4.5 mm" (or without σ); in metres when either reaches 1 m.
/// Shown only for a resolved residual ([`residual_shown`]).
pub(super) fn residual_text(res: &Residual) -> String {
    let big = res.drift_m.abs().max(res.std_m.unwrap_or(0.0)) >= 1.0;
    let (scale, unit) = if big { (1.0, "m") } else { (1000.0, "mm") };
    match res.std_m {
        Some(s) => format!(
            "{} ± {} {unit}",
            format_number(scale * res.drift_m),
            format_number(scale * s)
        ),
        None => format!("{} {unit}", format_number(scale * res.drift_m)),
    }
}

/// The residual drift as the page shows it: a resolved one with its value
/// and σ; an unresolved one or an artefact as words, without a number (it
/// says nothing either way).
pub(super) fn residual_shown(res: &Residual) -> Cell {
    if res.resolved() && !res.artefact() {
        Cell {
            value: Some(res.drift_m),
            class: Some("num"),
            ..Cell::text(&residual_text(res))
        }
    } else if res.artefact() {
        Cell::text("not resolved (baseline artefact)")
    } else {
        Cell::text("not resolved")
    }
}

pub(super) const RESIDUAL_METHOD: &str = "Residual drift: the storey's relative acceleration as recorded (upper minus lower level, \
     SI units, no filter, no taper) integrated twice from rest and baseline-corrected on the post-event window (from 95 % of its \
     Arias intensity, at least the last 10 % of the record), where the storey is at rest: a constant acceleration offset c is \
     fitted to the velocity there (v ≈ c t), and the residual drift is the mean over that window of the displacement minus \
     c t²/2. ± σ: the random walk that sensor noise (its density estimated in 0.6–0.9 × Nyquist) makes after double \
     integration, with the window's instability — a lower bound for non-white noise. A residual drift is rated only where \
     |D| ≥ 2σ (resolved) and it is not an artefact: more than twice its own row's peak drift, an offset the motion cannot have \
     reached (the band-pass takes at most about half of a real offset out of the tabled peak) — a baseline error, flagged and \
     never rated.";

/// The kinds of rows and how the rating uses them.
const KINDS_NOTE: &str = "Rows: <b>measured</b> — a storey between two instrumented levels; <b>segment</b> — several storeys \
     between two instrumented levels: the peak over time of the relative displacement of its end levels over the segment's \
     height, the average drift ratio of its storeys, and a lower bound of the largest of them; <b>estimate</b> — a storey \
     inside a segment, from the not-a-knot cubic spline of the displacement profile over the instrumented levels at each time \
     step (a parabola through three levels): an interpolation, not a measurement, shown and never rated. The rating uses the \
     measured storeys and the segment averages — what the records measure; a soft storey inside a segment is not seen by \
     either, so a segment's GREEN is weaker than a storey's.";

pub(super) fn drift_section(
    loaded: &Loaded,
    settings: &ReportSettings,
    out: &mut Vec<Assessment>,
) -> String {
    let mut body = String::new();
    if let Loaded::Ok(t) = loaded {
        if t.rows == 0 {
            body.push_str(&note(&format!(
                "No drift could be formed{}",
                if notes_of(t).is_empty() { "." } else { ":" }
            )));
            body.push_str(&notes_html(&notes_of(t)));
            return body;
        }
    }
    let Some(t) = require(loaded, &tables::DRIFT, &mut body) else {
        return body;
    };
    // The columns the table shows, then those the text below explains.
    let shown = [
        drift::DIRECTION.name,
        drift::KIND.name,
        drift::STOREY.name,
        drift::LOWER_LEVEL.name,
        drift::UPPER_LEVEL.name,
        drift::LOWER_CHANNEL.name,
        drift::UPPER_CHANNEL.name,
        drift::STOREY_HEIGHT_M.name,
        drift::HEIGHT_SOURCE.name,
    ];
    let known: Vec<&str> = shown
        .iter()
        .copied()
        .chain([
            drift::PEAK_DRIFT_RATIO.name,
            drift::RESIDUAL_DRIFT_M.name,
            drift::RESIDUAL_DRIFT_STD_M.name,
            drift::RESIDUAL_DRIFT_RATIO.name,
            drift::RESIDUAL_WINDOW_START_S.name,
            drift::METHOD.name,
            drift::RESIDUAL_STATUS.name,
        ])
        .collect();
    body.push_str(&column_notes(t, &known));
    let Some(ratio) = t.number(drift::PEAK_DRIFT_RATIO.name) else {
        return body;
    };
    let (th, rth) = (settings.drift, settings.residual_drift);
    body.push_str(&note(&format!(
        "Peak drift ratio: max over time of |u_upper − u_lower| / h from the band-passed displacements of the condition stage — the \
         oscillation only, since a band-pass removes a permanent offset by construction. Rating GREEN < {} ≤ YELLOW < {} ≤ RED.",
        short_number(th.yellow),
        short_number(th.red)
    )));
    if t.has(drift::KIND.name) {
        body.push_str(&format!("<p class=\"note\">{KINDS_NOTE}</p>"));
    }
    let assumed = (0..t.rows).any(|r| RowKind::of(t, r).assumed_height.is_some());
    if assumed {
        body.push_str(&note(
            "Storey heights ASSUMED (no storey heights, nor a total height with a storey count, stated for the structure): \
             the drift ratios and their ratings are provisional. State structure.storey_heights_m (or height_m and storeys) \
             in event.toml.",
        ));
    }
    body.push_str(&notes_html(&notes_of(t)));
    body.push_str(&note(&format!(
        "{RESIDUAL_METHOD} Rating of the residual drift ratio |D| / h: GREEN < {} ≤ YELLOW < {} ≤ RED.",
        short_number(rth.yellow),
        short_number(rth.red)
    )));
    let present = present_columns(t, &shown);
    let mut headers: Vec<String> = present.iter().map(|s| s.to_string()).collect();
    headers.extend(
        [
            drift::PEAK_DRIFT_RATIO.name,
            "peak drift (%)",
            "rating (peak)",
            "residual drift ± σ",
            "residual drift (%)",
            "rating (residual)",
        ]
        .map(String::from),
    );
    let mut rows = Vec::new();
    for r in 0..t.rows {
        let kind = RowKind::of(t, r);
        let provisional = kind.assumed_height.is_some();
        let v = ratio.get(r).copied().flatten();
        let rating = v.filter(|_| kind.rated()).and_then(|v| th.rate(v));
        let mut row: Vec<Cell> = present.iter().map(|c| Cell::of(t, c, r)).collect();
        row.push(Cell::of(t, drift::PEAK_DRIFT_RATIO.name, r));
        row.push(percent_cell(v));
        row.push(match (kind.rated(), rating) {
            (false, _) if kind.roof_level_assumed => Cell::text("roof level assumed: not rated"),
            (false, _) => Cell::text("estimate: not rated"),
            (true, rating) => rating_cell(rating),
        });
        if let (Some(v), Some(rating)) = (v, rating) {
            out.push(Assessment {
                criterion: PEAK_CRITERION.into(),
                subject: subject(t, r),
                value: v,
                rating,
                source: tables::DRIFT.file.into(),
                provisional,
            });
        }
        match residual(t, r) {
            None => {
                row.push(Cell::number(None));
                row.push(Cell::number(None));
                row.push(Cell::text("not available"));
            }
            Some(res) => {
                row.push(residual_shown(&res));
                row.push(if res.resolved() && !res.artefact() {
                    percent_cell(res.ratio)
                } else {
                    Cell::number(None)
                });
                let rated = res
                    .ratio
                    .filter(|_| res.resolved() && kind.rated())
                    .and_then(|x| rth.rate(x.abs()).map(|g| (x.abs(), g)));
                match rated {
                    Some((value, rating)) => {
                        row.push(rating_cell(Some(rating)));
                        out.push(Assessment {
                            criterion: RESIDUAL_CRITERION.into(),
                            subject: subject(t, r),
                            value,
                            rating,
                            source: tables::DRIFT.file.into(),
                            provisional,
                        });
                    }
                    None => row.push(Cell::text(res.why_not_rated())),
                }
            }
        }
        rows.push(row);
    }
    body.push_str(&format!(
        "<div class=\"scroll\">{}</div>",
        table(Some("drift-table"), &headers, &rows)
    ));
    if t.has(drift::STOREY.name) {
        body.push_str(&profile(t, ratio, settings));
    }
    body
}

fn percent_cell(v: Option<f64>) -> Cell {
    match v {
        Some(v) => Cell {
            value: Some(v),
            class: Some("num"),
            ..Cell::text(&format!("{:.3}", 100.0 * v))
        },
        None => Cell::number(None),
    }
}

/// Drift profile: storey on the vertical axis, one line per direction, the
/// thresholds as dashed lines — each inside the axis, or said to be beyond it.
fn profile(t: &Table, ratio: &[Option<f64>], settings: &ReportSettings) -> String {
    let th = settings.drift;
    let mut chart = Chart::new(520, 300, "peak inter-storey drift ratio", "storey");
    for (i, (dir, rows)) in t.groups(&[drift::DIRECTION.name]).into_iter().enumerate() {
        // Storeys (measured and estimated) as a line; segment averages as
        // hollow circles at the segment's mid-level.
        let (segments, storeys): (Vec<usize>, Vec<usize>) = rows
            .iter()
            .partition(|&&r| RowKind::of(t, r).kind == "segment");
        let mut pts: Vec<(f64, f64)> = rows_points(
            t,
            &storeys,
            drift::PEAK_DRIFT_RATIO.name,
            drift::STOREY.name,
        );
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        chart.series.push(Series::new(
            format!("direction {}", dir.join("")),
            pts,
            i,
            Mark::LinePoints,
        ));
        let level = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
        let averages: Vec<(f64, f64)> = segments
            .iter()
            .filter_map(|&r| {
                let mid = 0.5
                    * (level(drift::LOWER_LEVEL.name, r)?
                        + 1.0
                        + level(drift::UPPER_LEVEL.name, r)?);
                Some((ratio.get(r).copied().flatten()?, mid))
            })
            .collect();
        if !averages.is_empty() {
            chart.series.push(Series::new(
                format!("direction {}: segment average", dir.join("")),
                averages,
                i,
                Mark::HollowCircle,
            ));
        }
    }
    let max = ratio.iter().flatten().fold(0.0f64, |a, b| a.max(*b));
    // The axis reaches the yellow threshold, and the red one unless it would
    // squeeze the data into less than a third of the width.
    let mut hi = 1.1 * max.max(th.yellow);
    let red_drawn = th.red <= 3.0 * max.max(th.yellow);
    if red_drawn {
        hi = hi.max(1.08 * th.red);
    }
    chart.x_range = Some((0.0, hi));
    chart.y_pad = 0.12;
    chart.ref_lines.push(RefLine {
        at: th.yellow,
        horizontal: false,
        colour: 4,
    });
    if red_drawn {
        chart.ref_lines.push(RefLine {
            at: th.red,
            horizontal: false,
            colour: 1,
        });
    }
    let legend = plot::legend(&chart.series);
    let caption = if red_drawn {
        format!(
            "Peak drift ratio per storey (measured, or estimated inside a segment) and each segment's average (hollow circles, at its middle storey); dashed lines: yellow threshold {} (orange) and red threshold {} (vermillion)",
            short_number(th.yellow),
            short_number(th.red)
        )
    } else {
        format!(
            "Peak drift ratio per storey (measured, or estimated inside a segment) and each segment's average (hollow circles, at its middle storey); dashed line: yellow threshold {} (orange). The red threshold {} is off-scale (beyond the axis, more than 3 × the largest value shown)",
            short_number(th.yellow),
            short_number(th.red)
        )
    };
    figure(plot::render(&chart), &caption, &legend)
}
