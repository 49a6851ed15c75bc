//! The one-screen summary under the rating: the event, the shaking (PGA per
//! direction), per storey the peak and residual drift, the modes and their
//! shifts, ι per direction and what the twin update changed — each a small
//! table of values the later sections show in full.

use std::collections::BTreeMap;

use serde_json::Value;

use super::drift::{notes_of, residual, RowKind};
use super::event::{json_text, magnitude_text};
use super::{damage, rating_cell, stage_of, twin, Loaded, Outputs};
use crate::report::format_number;
use crate::report::html::{direction_text, escape, table, time_text, Cell};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{self, channels, drift, frequency_shifts, modes};
use crate::vocab::STANDARD_GRAVITY;

/// A card: title and body.
fn card(title: &str, body: &str) -> String {
    format!("<div class=\"card\"><h3>{}</h3>{body}</div>", escape(title))
}

/// A card two grid columns wide (a table of many columns).
fn card_wide(title: &str, body: &str) -> String {
    format!(
        "<div class=\"card wide\"><h3>{}</h3>{body}</div>",
        escape(title)
    )
}

/// One line saying why a card has nothing to show.
fn gap(file: &str, loaded: &Loaded) -> String {
    let why = match loaded {
        Loaded::Ok(t) if t.rows == 0 => super::empty_text(file),
        Loaded::Ok(_) => String::new(),
        Loaded::Absent(Some(why)) => format!("Not applicable: {why}."),
        Loaded::Absent(None) => format!(
            "No {}: stage {} not run.",
            super::label_of(file),
            stage_of(file)
        ),
        Loaded::Unreadable(_) => format!("The {} could not be read.", super::label_of(file)),
    };
    format!("<p class=\"note\">{}</p>", escape(&why))
}

fn ok(loaded: &Loaded) -> Option<&Table> {
    match loaded {
        Loaded::Ok(t) if t.rows > 0 => Some(t),
        _ => None,
    }
}

pub(super) fn summary_section(
    dir: &std::path::Path,
    event: &Result<Value, String>,
    o: &Outputs,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    if let Ok(ev) = event {
        let structure = ev
            .get("structure")
            .and_then(|s| s.get("name"))
            .map(|n| json_text(Some(n)));
        let mut facts = vec![
            json_text(ev.get("name")),
            format!("origin {}", time_text(&json_text(ev.get("origin_time")))),
            format!("M {}", magnitude_text(ev.get("magnitude"))),
        ];
        facts.extend(structure.map(|s| format!("structure: {s}")));
        facts.extend(
            super::title::epicentral_distance_km(ev)
                .map(|d| format!("epicentral distance {d:.1} km")),
        );
        body.push_str(&format!(
            "<p class=\"lead\">{}</p>",
            escape(&facts.join(" · "))
        ));
    }
    body.push_str("<div class=\"glance\">");
    // Wide cards (many columns) beside narrow ones: two rows on a screen.
    body.push_str(&card_wide("Shaking", &shaking(&o.channels)));
    body.push_str(&card("Damage index ι", &iota_card(&o.damage, settings)));
    body.push_str(&card_wide("Storeys: drift", &storeys(&o.drift, settings)));
    body.push_str(&card("Modes", &modes_card(&o.modes, &o.shifts)));
    body.push_str(&card("Twin update", &twin_card(o)));
    // A test-design run: the design in facts.
    let design = super::design::design_facts(dir);
    if !design.is_empty() {
        body.push_str(&card_wide(
            "Hybrid-test design",
            &super::design::facts_list(&design),
        ));
    }
    body.push_str("</div>");
    body
}

/// Peak ground acceleration per direction (base channels: level 0 or role
/// input) and the peak floor acceleration.
fn shaking(loaded: &Loaded) -> String {
    let Some(t) = ok(loaded) else {
        return gap(tables::CHANNELS.file, loaded);
    };
    let Some(pga) = t.number(channels::PGA_M_S2.name) else {
        return "<p class=\"note\">The channel table has no PGA.</p>".into();
    };
    // direction → (ground peak, its channel), (floor peak, its channel)
    type Peak = Option<(f64, String)>;
    let mut by_dir: BTreeMap<String, (Peak, Peak)> = BTreeMap::new();
    for r in 0..t.rows {
        let Some(a) = pga.get(r).copied().flatten() else {
            continue;
        };
        let dir = t
            .key(channels::DIRECTION.name, r)
            .unwrap_or_else(|| "direction unknown".into());
        let id = t.key(channels::CHANNEL_ID.name, r).unwrap_or_default();
        let ground = t.key(channels::LEVEL.name, r).as_deref() == Some("0")
            || t.key(channels::ROLE.name, r).as_deref() == Some("input");
        let entry = by_dir.entry(dir).or_default();
        let slot = if ground { &mut entry.0 } else { &mut entry.1 };
        if slot.as_ref().is_none_or(|(v, _)| a > *v) {
            *slot = Some((a, id));
        }
    }
    // Value (m/s², and g) and the channel, in two columns per kind.
    let peak = |p: &Peak| match p {
        Some((v, id)) => vec![
            Cell {
                value: Some(*v),
                class: Some("num"),
                ..Cell::text(&format!(
                    "{} ({} g)",
                    format_number(*v),
                    format_number(v / STANDARD_GRAVITY)
                ))
            },
            Cell::text(id),
        ],
        None => vec![Cell::number(None), Cell::text("")],
    };
    let rows: Vec<Vec<Cell>> = by_dir
        .iter()
        .map(|(d, (g, f))| {
            let mut row = vec![Cell::text(&direction_text(d))];
            row.extend(peak(g));
            row.extend(peak(f));
            row
        })
        .collect();
    table(
        Some("summary-shaking"),
        &[
            "direction",
            "PGA, m/s² (g)",
            "channel",
            "peak floor, m/s² (g)",
            "channel",
        ]
        .map(String::from),
        &rows,
    )
}

/// Per storey or segment: peak drift ratio and residual drift, each with
/// its rating (estimates shown, not rated; assumed heights said).
fn storeys(loaded: &Loaded, settings: &ReportSettings) -> String {
    let Some(t) = ok(loaded) else {
        if let Loaded::Ok(t) = loaded {
            let notes = notes_of(t);
            if !notes.is_empty() {
                return format!(
                    "<p class=\"note\">No drift: {}</p>",
                    escape(&notes.join("; "))
                );
            }
        }
        return gap(tables::DRIFT.file, loaded);
    };
    let peak = t.number(drift::PEAK_DRIFT_RATIO.name);
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| {
            let kind = RowKind::of(t, r);
            let v = peak.and_then(|p| p.get(r).copied().flatten());
            let res = residual(t, r);
            let residual_rating = res
                .as_ref()
                .filter(|x| x.resolved() && kind.rated())
                .and_then(|x| settings.residual_drift.rate(x.ratio?.abs()));
            let place = match kind.kind.as_str() {
                "segment" => format!(
                    "{}–{} (segment)",
                    t.key(drift::LOWER_LEVEL.name, r).unwrap_or_default(),
                    t.key(drift::UPPER_LEVEL.name, r).unwrap_or_default()
                ),
                "estimate" => format!(
                    "{} (estimate)",
                    t.key(drift::STOREY.name, r).unwrap_or_default()
                ),
                _ => t.key(drift::STOREY.name, r).unwrap_or_default(),
            };
            let assumed = if kind.assumed_height.is_some() {
                " (assumed height)"
            } else {
                ""
            };
            vec![
                Cell::text(&t.key(drift::DIRECTION.name, r).unwrap_or_default()),
                Cell::text(&place),
                Cell {
                    value: v,
                    class: Some("num"),
                    ..Cell::text(
                        &v.map(|v| format!("{:.3} %{assumed}", 100.0 * v))
                            .unwrap_or("—".into()),
                    )
                },
                if kind.rated() {
                    rating_cell(v.and_then(|v| settings.drift.rate(v)))
                } else {
                    Cell::text("not rated")
                },
                match &res {
                    Some(x) => super::drift::residual_shown(x),
                    None => Cell::number(None),
                },
                match (res, residual_rating) {
                    (_, Some(g)) => rating_cell(Some(g)),
                    (Some(_), None) => Cell::text("not rated"),
                    (None, None) => Cell::text("—"),
                },
            ]
        })
        .collect();
    table(
        Some("summary-storeys"),
        &[
            "direction",
            "storey",
            "peak drift",
            "rating",
            "residual drift ± σ",
            "rating",
        ]
        .map(String::from),
        &rows,
    )
}

/// Modes: frequency, damping, direction and, with a reference event, the
/// shift of the paired mode.
fn modes_card(loaded: &Loaded, shifts: &Loaded) -> String {
    let Some(t) = ok(loaded) else {
        return gap(tables::MODES.file, loaded);
    };
    // current mode → (shift %, σ %, significant)
    let mut shift: BTreeMap<String, String> = BTreeMap::new();
    if let Some(s) = ok(shifts) {
        for r in 0..s.rows {
            let num = |c: &str| s.number(c).and_then(|v| v.get(r).copied().flatten());
            if let (Some(m), Some(x)) = (
                s.key(frequency_shifts::CURRENT_MODE.name, r),
                num(frequency_shifts::SHIFT_PERCENT.name),
            ) {
                let sd = num(frequency_shifts::SHIFT_STD_PERCENT.name)
                    .map(|sd| format!(" ± {}", format_number(sd)))
                    .unwrap_or_default();
                let sig = match s
                    .boolean(frequency_shifts::SIGNIFICANT.name)
                    .and_then(|v| v.get(r).copied().flatten())
                {
                    Some(true) => " (significant)",
                    _ => "",
                };
                shift.insert(m, format!("{}{sd} %{sig}", format_number(x)));
            }
        }
    }
    let with_shift = ok(shifts).is_some();
    let num = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| {
            let mode = t.key(modes::MODE.name, r).unwrap_or_default();
            let mut row = vec![
                Cell::text(&mode),
                Cell::number(num(modes::FREQUENCY_HZ.name, r)),
                Cell::number(num(modes::DAMPING_RATIO.name, r).map(|z| 100.0 * z)),
                Cell::direction(t, modes::DIRECTION.name, r),
            ];
            if with_shift {
                row.push(Cell::text(
                    shift.get(&mode).map(String::as_str).unwrap_or("unpaired"),
                ));
            }
            row
        })
        .collect();
    let mut headers: Vec<String> = ["mode", "f (Hz)", "ζ (%)", "direction"]
        .map(String::from)
        .to_vec();
    if with_shift {
        headers.push("shift vs reference".into());
    }
    table(Some("summary-modes"), &headers, &rows)
}

fn iota_card(loaded: &Loaded, settings: &ReportSettings) -> String {
    if matches!(loaded, Loaded::Ok(t) if t.rows == 0) {
        return format!("<p class=\"note\">{}.</p>", escape(damage::NO_ROWS));
    }
    let Some(t) = ok(loaded) else {
        return gap(tables::DAMAGE.file, loaded);
    };
    let rows: Vec<Vec<Cell>> = damage::iota_by_direction(t)
        .into_iter()
        .map(|(dir, final_v, peak_v)| {
            let rated = match settings.iota_statistic {
                crate::report::IotaStatistic::Final => final_v,
                crate::report::IotaStatistic::Peak => peak_v,
            };
            vec![
                Cell::text(&dir),
                Cell::number(final_v),
                Cell::number(peak_v),
                rating_cell(rated.and_then(|v| settings.iota.rate(v))),
            ]
        })
        .collect();
    table(
        Some("summary-iota"),
        &["direction", "final ι", "peak ι", "rating"].map(String::from),
        &rows,
    )
}

fn twin_card(o: &Outputs) -> String {
    let Some(t) = ok(&o.twin_update) else {
        return gap(tables::TWIN_UPDATE.file, &o.twin_update);
    };
    let rows: Vec<Vec<Cell>> = twin::parameter_changes(t)
        .iter()
        .map(|p| {
            vec![
                Cell::text(&p.name),
                Cell::text(&format!(
                    "{} → {}",
                    p.start.map(format_number).unwrap_or("—".into()),
                    p.calibrated.map(format_number).unwrap_or("—".into())
                )),
                Cell::number(p.change_percent()),
            ]
        })
        .collect();
    let mut html = table(
        Some("summary-twin"),
        &["parameter", "start → calibrated", "change (%)"].map(String::from),
        &rows,
    );
    if let Some(m) = ok(&o.twin_modes) {
        let summary: Option<Value> = m
            .metadata
            .get("quaketwin.summary")
            .and_then(|s| serde_json::from_str(s).ok());
        let f = |stage: &str| {
            summary
                .as_ref()?
                .get(stage)?
                .get("frequency_error")?
                .as_f64()
        };
        if let (Some(a), Some(b)) = (f("initial"), f("updated")) {
            html.push_str(&format!(
                "<p>Mean frequency error {} % → {} %.</p>",
                format_number(100.0 * a),
                format_number(100.0 * b)
            ));
        }
    }
    html
}
