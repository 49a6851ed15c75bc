//! The title block a report opens with — structure (name, id, address,
//! position), event (origin time, magnitude, epicentre and epicentral
//! distance), report date, software and pipeline — and the review block
//! (prepared by / reviewed by / approved, with empty lines to sign).
//! Everything from `event.json` and `run.json`; the epicentral distance is
//! the great-circle distance from the epicentre to the structure's stated
//! position, else to the recording station's position in the headers.

use std::path::Path;

use serde_json::Value;

use super::event::{json_text, magnitude_text};
use crate::report::html::{escape, natural_cmp, time_text};
use crate::report::ReportSettings;

/// "35.670° N, 117.819° W".
fn position_text(lat: f64, lon: f64) -> String {
    format!(
        "{:.3}° {}, {:.3}° {}",
        lat.abs(),
        if lat >= 0.0 { "N" } else { "S" },
        lon.abs(),
        if lon >= 0.0 { "E" } else { "W" }
    )
}

fn pair(v: Option<&Value>, a: &str, b: &str) -> Option<(f64, f64)> {
    let v = v?;
    Some((v.get(a)?.as_f64()?, v.get(b)?.as_f64()?))
}

/// The structure's position and where it comes from: stated (event.toml),
/// else the recording station's from the record headers.
pub(super) fn structure_position(ev: &Value) -> Option<((f64, f64), &'static str)> {
    if let Some(p) = pair(ev.get("structure"), "latitude_deg", "longitude_deg") {
        return Some((p, "stated"));
    }
    let s = ev.get("station_position")?.as_array()?;
    Some((
        (s.first()?.as_f64()?, s.get(1)?.as_f64()?),
        "recording station, from the record headers",
    ))
}

/// Epicentre (lat, lon) and depth (km), when event.json has them.
pub(super) fn epicentre(ev: &Value) -> Option<((f64, f64), Option<f64>)> {
    let h = ev.get("hypocentre")?;
    let p = pair(Some(h), "latitude_deg", "longitude_deg")?;
    Some((p, h.get("depth_km").and_then(Value::as_f64)))
}

/// Epicentral distance, km, when both positions are known.
pub(super) fn epicentral_distance_km(ev: &Value) -> Option<f64> {
    let ((la, lo), _) = epicentre(ev)?;
    let ((sa, so), _) = structure_position(ev)?;
    Some(crate::geometry::great_circle_km(la, lo, sa, so))
}

/// Network and station codes of the event's channels ("CE 33742").
fn station_codes(ev: &Value) -> Vec<String> {
    let mut codes: Vec<String> = ev
        .get("channels")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|c| {
                    // A station code comes with its network (a CSV or AT2
                    // file's "station" is free text, not a code).
                    let sta = c.get("station")?.as_str()?.trim();
                    let net = c.get("network")?.as_str()?.trim();
                    (!sta.is_empty() && !net.is_empty()).then(|| format!("{net} {sta}"))
                })
                .collect()
        })
        .unwrap_or_default();
    codes.sort_by(|a, b| natural_cmp(a, b));
    codes.dedup();
    codes
}

/// The date the page states: the `date` setting, else `SOURCE_DATE_EPOCH`
/// (seconds, the reproducible-builds convention), else today (UTC).
pub(crate) fn report_date(settings: &ReportSettings) -> String {
    if let Some(d) = &settings.date {
        return d.clone();
    }
    let secs = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs() as i64)
                .unwrap_or(0)
        });
    crate::vocab::format_epoch_ns(secs.saturating_mul(1_000_000_000))
        .split('T')
        .next()
        .unwrap_or_default()
        .to_string()
}

/// The facts of the title block, (label, text), "not stated" where unknown.
pub(super) fn title_facts(
    dir: &Path,
    event: &Result<Value, String>,
    settings: &ReportSettings,
) -> Vec<(String, String)> {
    let mut facts: Vec<(String, String)> = Vec::new();
    let unknown = |what: &str| format!("not stated ({what})");
    let ev = event.as_ref().ok();
    let structure = ev.and_then(|e| e.get("structure"));
    let s = |k: &str| {
        structure
            .and_then(|s| s.get(k))
            .filter(|v| !v.is_null())
            .map(|v| json_text(Some(v)))
    };
    let mut name = s("name").unwrap_or_else(|| unknown("structure.name in event.toml"));
    if let Some(kind) = s("kind") {
        name.push_str(&format!(" ({kind})"));
    }
    facts.push(("Structure".into(), name));
    let codes = ev.map(station_codes).unwrap_or_default();
    let id = match (s("id"), codes.is_empty()) {
        (Some(id), true) => id,
        (Some(id), false) => format!("{id} · station {}", codes.join(", ")),
        (None, false) => format!("station {}", codes.join(", ")),
        (None, true) => unknown("structure.id"),
    };
    facts.push(("Structure id".into(), id));
    facts.push((
        "Address".into(),
        s("address").unwrap_or_else(|| unknown("structure.address")),
    ));
    facts.push((
        "Coordinates".into(),
        match ev.and_then(structure_position) {
            Some(((lat, lon), how)) => format!("{} ({how})", position_text(lat, lon)),
            None => unknown("structure.latitude_deg, longitude_deg"),
        },
    ));
    let mut event_text = ev
        .and_then(|e| e.get("name"))
        .map(|n| json_text(Some(n)))
        .unwrap_or_else(|| "—".into());
    if let Some(e) = ev {
        let origin = e.get("origin_time").filter(|v| !v.is_null());
        event_text.push_str(&match origin {
            Some(o) => format!(", origin {}", time_text(&json_text(Some(o)))),
            None => ", origin time not stated".into(),
        });
        let mag = e.get("magnitude").filter(|v| !v.is_null());
        event_text.push_str(&match mag {
            Some(m) => format!(", M {}", magnitude_text(Some(m))),
            None => ", magnitude not stated".into(),
        });
    }
    facts.push(("Event".into(), event_text));
    facts.push((
        "Epicentre".into(),
        match ev.and_then(epicentre) {
            Some(((lat, lon), depth)) => format!(
                "{}{}",
                position_text(lat, lon),
                depth
                    .map(|d| format!(", depth {d:.0} km"))
                    .unwrap_or_default()
            ),
            None => unknown("event.latitude_deg, longitude_deg"),
        },
    ));
    facts.push((
        "Epicentral distance".into(),
        match ev.and_then(epicentral_distance_km) {
            Some(d) => format!("{d:.1} km (great circle, epicentre to structure)"),
            None => "not known (needs the epicentre and the structure's position)".into(),
        },
    ));
    facts.push(("Report date".into(), report_date(settings)));
    let manifest = crate::pipeline::manifest::read(dir).ok().flatten();
    let mut software = format!("quaketwin {}", env!("CARGO_PKG_VERSION"));
    if let Some(m) = &manifest {
        software.push_str(&format!(", pipeline “{}”", m.pipeline));
        if m.quaketwin_version != env!("CARGO_PKG_VERSION") {
            software.push_str(&format!(
                " (outputs written by quaketwin {})",
                m.quaketwin_version
            ));
        }
    }
    facts.push(("Software".into(), software));
    facts
}

/// The title block: a two-column grid of facts.
pub(super) fn title_block(
    dir: &Path,
    event: &Result<Value, String>,
    settings: &ReportSettings,
) -> String {
    let mut html = String::from("<dl class=\"facts title-block\" id=\"title-block\">");
    for (k, v) in title_facts(dir, event, settings) {
        html.push_str(&format!("<dt>{}</dt><dd>{}</dd>", escape(&k), escape(&v)));
    }
    html.push_str("</dl>");
    html
}

/// The review block: who prepared, reviewed and approved the report, with
/// empty lines for name, signature and date.
pub(super) fn review_block() -> String {
    let mut html = String::from(
        "<table class=\"review-block\" id=\"review-block\"><thead><tr><th></th><th>Name</th><th>Signature</th><th>Date</th></tr></thead><tbody>",
    );
    for role in ["Prepared by", "Reviewed by", "Approved by"] {
        html.push_str(&format!(
            "<tr><th>{role}</th><td class=\"sign\"></td><td class=\"sign\"></td><td class=\"sign\"></td></tr>"
        ));
    }
    html.push_str("</tbody></table>");
    html
}
