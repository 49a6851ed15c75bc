//! Inter-storey drift (drift.parquet): peak drift ratio from the band-passed
//! displacements and residual drift from the unfiltered records, their
//! ratings and the profile chart.

use super::{figure, present_columns, rating_cell, require, rows_points, Loaded};
use crate::report::format_number;
use crate::report::html::{column_notes, note, short_number, table, Cell};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::Table;
use crate::report::{Assessment, ReportSettings};
use crate::vocab::tables::{self, drift};

/// Criterion names, as the rating section lists them.
pub(super) const PEAK_CRITERION: &str = "peak inter-storey drift ratio";
pub(super) const RESIDUAL_CRITERION: &str = "residual inter-storey drift ratio";

/// The residual drift of one row: value, σ and ratio, when tabled.
#[derive(Debug, Clone, Copy)]
pub(super) struct Residual {
    pub drift_m: f64,
    pub std_m: Option<f64>,
    pub ratio: Option<f64>,
}

impl Residual {
    /// |D| ≥ 2σ (the metrics stage's rule; no σ tabled: not resolved).
    pub fn resolved(&self) -> bool {
        self.std_m
            .is_some_and(|s| s.is_finite() && self.drift_m.abs() >= 2.0 * s)
    }
}

/// The residual drift of row `r` of drift.parquet.
pub(super) fn residual(t: &Table, r: usize) -> Option<Residual> {
    let num = |c: &str| t.number(c).and_then(|v| v.get(r).copied().flatten());
    Some(Residual {
        drift_m: num(drift::RESIDUAL_DRIFT_M.name)?,
        std_m: num(drift::RESIDUAL_DRIFT_STD_M.name),
        ratio: num(drift::RESIDUAL_DRIFT_RATIO.name),
    })
}

/// "storey 2, direction X" of row `r`.
pub(super) fn subject(t: &Table, r: usize) -> String {
    format!(
        "storey {}, direction {}",
        t.key(drift::STOREY.name, r).unwrap_or_else(|| "?".into()),
        t.key(drift::DIRECTION.name, r)
            .unwrap_or_else(|| "?".into())
    )
}

/// "−12.3 ± 4.5 mm" (or without σ); in metres when either reaches 1 m (an
/// unresolved estimate of a noisy record).
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

pub(super) const RESIDUAL_METHOD: &str = "Residual drift: the storey's relative acceleration as recorded (upper minus lower level, \
     SI units, no filter, no taper) integrated twice from rest and baseline-corrected on the post-event window (from 95 % of its \
     Arias intensity, at least the last 10 % of the record), where the storey is at rest: a constant acceleration offset c is \
     fitted to the velocity there (v ≈ c t), and the residual drift is the mean over that window of the displacement minus \
     c t²/2. ± σ: the random walk that sensor noise (its density estimated in 0.6–0.9 × Nyquist) makes after double \
     integration, with the window's instability — a lower bound for non-white noise. A residual drift is rated only where \
     |D| ≥ 2σ (resolved).";

pub(super) fn drift_section(
    loaded: &Loaded,
    settings: &ReportSettings,
    out: &mut Vec<Assessment>,
) -> String {
    let mut body = String::new();
    let Some(t) = require(loaded, &tables::DRIFT, &mut body) else {
        return body;
    };
    let known = [
        drift::DIRECTION.name,
        drift::STOREY.name,
        drift::LOWER_CHANNEL.name,
        drift::UPPER_CHANNEL.name,
        drift::STOREY_HEIGHT_M.name,
        drift::PEAK_DRIFT_RATIO.name,
        drift::RESIDUAL_DRIFT_M.name,
        drift::RESIDUAL_DRIFT_STD_M.name,
        drift::RESIDUAL_DRIFT_RATIO.name,
        drift::RESIDUAL_WINDOW_START_S.name,
    ];
    body.push_str(&column_notes(t, &known));
    let Some(ratio) = t.number(drift::PEAK_DRIFT_RATIO.name) else {
        return body;
    };
    let (th, rth) = (settings.drift, settings.residual_drift);
    body.push_str(&note(&format!(
        "Peak drift ratio: max over time of |u_L − u_L−1| / h_L from the band-passed displacements of the condition stage — the \
         oscillation only, since a band-pass removes a permanent offset by construction. Rating GREEN < {} ≤ YELLOW < {} ≤ RED.",
        short_number(th.yellow),
        short_number(th.red)
    )));
    body.push_str(&note(&format!(
        "{RESIDUAL_METHOD} Rating of the residual drift ratio |D| / h: GREEN < {} ≤ YELLOW < {} ≤ RED.",
        short_number(rth.yellow),
        short_number(rth.red)
    )));
    let present = present_columns(t, &known[..5]);
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
        let v = ratio.get(r).copied().flatten();
        let rating = v.and_then(|v| th.rate(v));
        let mut row: Vec<Cell> = present.iter().map(|c| Cell::of(t, c, r)).collect();
        row.push(Cell::of(t, drift::PEAK_DRIFT_RATIO.name, r));
        row.push(percent_cell(v));
        row.push(rating_cell(rating));
        if let (Some(v), Some(rating)) = (v, rating) {
            out.push(Assessment {
                criterion: PEAK_CRITERION.into(),
                subject: subject(t, r),
                value: v,
                rating,
                source: tables::DRIFT.file.into(),
            });
        }
        match residual(t, r) {
            None => {
                row.push(Cell::number(None));
                row.push(Cell::number(None));
                row.push(Cell::text("not available"));
            }
            Some(res) => {
                row.push(Cell {
                    value: Some(res.drift_m),
                    class: Some("num"),
                    ..Cell::text(&residual_text(&res))
                });
                row.push(percent_cell(res.ratio));
                let rated = res
                    .ratio
                    .filter(|_| res.resolved())
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
                        });
                    }
                    None => row.push(Cell::text("not resolved (|D| < 2σ)")),
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
        let mut pts: Vec<(f64, f64)> =
            rows_points(t, &rows, drift::PEAK_DRIFT_RATIO.name, drift::STOREY.name);
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        chart.series.push(Series::new(
            format!("direction {}", dir.join("")),
            pts,
            i,
            Mark::LinePoints,
        ));
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
            "Peak drift ratio per storey; dashed lines: yellow threshold {} (orange) and red threshold {} (vermillion)",
            short_number(th.yellow),
            short_number(th.red)
        )
    } else {
        format!(
            "Peak drift ratio per storey; dashed line: yellow threshold {} (orange). The red threshold {} is off-scale (beyond the axis, more than 3 × the largest value shown)",
            short_number(th.yellow),
            short_number(th.red)
        )
    };
    figure(plot::render(&chart), &caption, &legend)
}
