//! The sensor layout as an elevation sketch (inline SVG, not to scale): one
//! row per instrumented level — named, with its height above the base when
//! the structure states its storey heights — or, for a structure without
//! levels (a bridge), one row per sensor location of the headers; on each
//! row its channels with their direction (→ X in the drawing plane, ⊙ Y out
//! of it, ↑ ↓ vertical, ↗ an azimuth), the inputs (base motion) in orange.
//! Read from `event.json` (the channels after the geometry of the ingest),
//! so it is the same in every pipeline.  Also home of how the page names a
//! level and orders channels.

use std::collections::BTreeMap;

use serde_json::Value;

use crate::report::html::{escape, natural_cmp};

/// One sensor channel of the event, as the sketch draws it.
#[derive(Debug, Clone)]
pub(super) struct Sensor {
    pub id: String,
    pub level: Option<i32>,
    pub place: Option<String>,
    /// `X`, `Y`, `Z`, `UP`, `DOWN` or `<az>deg`; empty when unknown.
    pub direction: String,
    pub input: bool,
}

/// A channel's direction as event.json serialises it (`{"Axis": "X"}`,
/// `{"Azimuth": 270.0}`, `"Up"`, `"Down"`) in the tables' words.
fn direction_of(v: Option<&Value>) -> String {
    match v {
        Some(Value::Object(m)) => {
            if let Some(a) = m.get("Axis").and_then(Value::as_str) {
                a.to_string()
            } else if let Some(az) = m.get("Azimuth").and_then(Value::as_f64) {
                format!("{az}deg")
            } else {
                String::new()
            }
        }
        Some(Value::String(s)) => s.to_ascii_uppercase(),
        _ => String::new(),
    }
}

/// The recording channels of event.json (a rigid-floor combination, which
/// no sensor records, left out), in natural order of their ids.
pub(super) fn sensors(ev: &Value) -> Vec<Sensor> {
    let mut out: Vec<Sensor> = ev
        .get("channels")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .filter(|c| {
                    c.get("combines")
                        .and_then(Value::as_array)
                        .is_none_or(|x| x.is_empty())
                })
                .filter_map(|c| {
                    Some(Sensor {
                        id: c.get("id")?.as_str()?.to_string(),
                        level: c.get("level").and_then(Value::as_i64).map(|l| l as i32),
                        place: c
                            .get("location_text")
                            .and_then(Value::as_str)
                            .map(str::trim)
                            .filter(|s| !s.is_empty())
                            .map(str::to_string),
                        direction: direction_of(c.get("direction")),
                        input: c.get("role").and_then(Value::as_str) == Some("input"),
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    out.sort_by(|a, b| natural_cmp(&a.id, &b.id));
    out
}

/// Storey count of the structure (event.json), when known.
pub(super) fn storeys(ev: &Value) -> Option<i32> {
    let s = ev.get("structure")?;
    if let Some(n) = s.get("storeys").and_then(Value::as_i64) {
        return Some(n as i32);
    }
    // Stated storey heights: one per storey.
    let heights = s.get("storey_heights_m")?.as_array()?;
    (!heights.is_empty()).then_some(heights.len() as i32)
}

/// Height of each level above the base, m (level 0 = 0), when the structure
/// states its storey heights (or a total height with a storey count).
fn level_heights(ev: &Value) -> Option<Vec<f64>> {
    let s = ev.get("structure")?;
    let stated: Vec<f64> = s
        .get("storey_heights_m")
        .and_then(Value::as_array)
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default();
    let heights = if !stated.is_empty() {
        stated
    } else {
        let (h, n) = (s.get("height_m")?.as_f64()?, s.get("storeys")?.as_u64()?);
        (n > 0 && h > 0.0).then(|| vec![h / n as f64; n as usize])?
    };
    let mut acc = vec![0.0];
    for h in heights {
        acc.push(acc.last().copied().unwrap_or(0.0) + h);
    }
    Some(acc)
}

/// How the page names a level: "level 0 (base)", "level 7 (roof)" when the
/// storey count says so, else "level 3".
pub(crate) fn level_name(level: i32, storeys: Option<i32>) -> String {
    if level == 0 {
        "level 0 (base)".into()
    } else if Some(level) == storeys {
        format!("level {level} (roof)")
    } else {
        format!("level {level}")
    }
}

/// Where a channel is, in words: its level, else the sensor location the
/// header gives, else "level unknown".
pub(crate) fn place_text(level: Option<i32>, place: Option<&str>, storeys: Option<i32>) -> String {
    match (level, place) {
        (Some(l), _) => level_name(l, storeys),
        (None, Some(p)) => p.to_string(),
        (None, None) => "level unknown".into(),
    }
}

/// The glyph of a direction: → X (in the drawing plane), ⊙ Y (out of it),
/// ↑ up / Z, ↓ down, ↗ an azimuth, ? unknown.
fn glyph(direction: &str) -> (String, String) {
    match direction {
        "X" => ("→".into(), "X".into()),
        "Y" => ("⊙".into(), "Y".into()),
        "Z" | "UP" => ("↑".into(), "up".into()),
        "DOWN" => ("↓".into(), "down".into()),
        d => match d.strip_suffix("deg") {
            Some(az) => ("↗".into(), format!("{az}°")),
            None => ("?".into(), "direction unknown".into()),
        },
    }
}

/// Rows of the sketch, top first: (label, sensors).
fn rows(ev: &Value, sensors: &[Sensor]) -> Vec<(String, Vec<Sensor>)> {
    let n = storeys(ev);
    let heights = level_heights(ev);
    let mut by_level: BTreeMap<i32, Vec<Sensor>> = BTreeMap::new();
    let mut by_place: BTreeMap<String, Vec<Sensor>> = BTreeMap::new();
    for s in sensors {
        match s.level {
            Some(l) => by_level.entry(l).or_default().push(s.clone()),
            None => by_place
                .entry(s.place.clone().unwrap_or_else(|| "level unknown".into()))
                .or_default()
                .push(s.clone()),
        }
    }
    let mut out: Vec<(String, Vec<Sensor>)> = Vec::new();
    for (level, list) in by_level.into_iter().rev() {
        let height = heights
            .as_ref()
            .and_then(|h| h.get(level as usize))
            .map(|h| format!(" · {h:.1} m"))
            .unwrap_or_default();
        out.push((format!("{}{height}", level_name(level, n)), list));
    }
    // Places without a level: those holding inputs (the ground) last.
    let mut places: Vec<(String, Vec<Sensor>)> = by_place.into_iter().collect();
    places.sort_by(|a, b| {
        let input = |l: &[Sensor]| l.iter().any(|s| s.input);
        input(&a.1)
            .cmp(&input(&b.1))
            .then_with(|| natural_cmp(&a.0, &b.0))
    });
    out.extend(places);
    out
}

/// Channels drawn per line of a row, and the width of each.
const PER_LINE: usize = 3;
const COLUMN_W: f64 = 200.0;
const LINE_H: f64 = 20.0;
const PAD: f64 = 8.0;
/// Width of a label character at 12 px (sans-serif, generous).
const CHAR_W: f64 = 7.0;

/// The sketch as an inline SVG figure with its caption; empty without channels.
pub(super) fn layout_figure(ev: &Value) -> String {
    let sensors = sensors(ev);
    if sensors.is_empty() {
        return String::new();
    }
    let rows = rows(ev, &sensors);
    let has_levels = sensors.iter().any(|s| s.level.is_some());
    let heights: Vec<f64> = rows
        .iter()
        .map(|(_, l)| l.len().div_ceil(PER_LINE).max(1) as f64 * LINE_H + 2.0 * PAD)
        .collect();
    let total: f64 = heights.iter().sum::<f64>() + 2.0 * PAD;
    // The label column as wide as the longest label (a bridge's locations).
    let longest = rows
        .iter()
        .map(|(l, _)| l.chars().count())
        .max()
        .unwrap_or(0);
    let label_w = (longest as f64 * CHAR_W + 20.0).clamp(140.0, 420.0);
    let width = label_w + 84.0 + PER_LINE as f64 * COLUMN_W;
    let mut svg = format!(
        "<svg class=\"plot layout\" viewBox=\"0 0 {width:.0} {total:.0}\" width=\"{width:.0}\" height=\"{total:.0}\" role=\"img\" aria-label=\"sensor layout\">",
    );
    let (bx0, bx1) = (label_w, label_w + 70.0);
    let mut y = PAD;
    let mut slab_ys = Vec::new();
    for ((label, list), h) in rows.iter().zip(&heights) {
        let mid = y + h / 2.0;
        svg.push_str(&format!(
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\" font-size=\"12\" fill=\"#1b1b1b\">{}</text>",
            label_w - 10.0,
            mid + 4.0,
            escape(label)
        ));
        if has_levels && list.iter().all(|s| s.level.is_some()) {
            slab_ys.push(y + h - PAD / 2.0);
            svg.push_str(&format!(
                "<line x1=\"{bx0}\" y1=\"{0:.1}\" x2=\"{bx1}\" y2=\"{0:.1}\" stroke=\"#555\" stroke-width=\"3\"/>",
                y + h - PAD / 2.0
            ));
        } else {
            svg.push_str(&format!(
                "<rect x=\"{bx0}\" y=\"{:.1}\" width=\"{}\" height=\"{:.1}\" fill=\"#f5f5f5\" stroke=\"#999\"/>",
                y + 2.0,
                bx1 - bx0,
                h - 4.0
            ));
        }
        for (i, s) in list.iter().enumerate() {
            let (line, col) = (i / PER_LINE, i % PER_LINE);
            let x = bx1 + 14.0 + col as f64 * COLUMN_W;
            let ty = y + PAD + line as f64 * LINE_H + 14.0;
            let (g, dir) = glyph(&s.direction);
            let colour = if s.input { "#d55e00" } else { "#0072b2" };
            let role = if s.input { ", input" } else { "" };
            svg.push_str(&format!(
                "<text x=\"{x:.1}\" y=\"{ty:.1}\" font-size=\"12\" fill=\"{colour}\"{}><tspan font-size=\"14\">{}</tspan> {} <tspan fill=\"#555\">({}{role})</tspan></text>",
                if s.input { " font-weight=\"bold\"" } else { "" },
                escape(&g),
                escape(&s.id),
                escape(&dir)
            ));
        }
        y += h;
    }
    // The structure's columns between the lowest and the highest slab.
    if let (Some(top), Some(bottom)) = (slab_ys.first(), slab_ys.last()) {
        if slab_ys.len() > 1 {
            for x in [bx0, bx1] {
                svg.push_str(&format!(
                    "<line x1=\"{x}\" y1=\"{top:.1}\" x2=\"{x}\" y2=\"{bottom:.1}\" stroke=\"#555\" stroke-width=\"1.5\"/>"
                ));
            }
        }
        svg.push_str(&format!(
            "<line x1=\"{:.1}\" y1=\"{bottom:.1}\" x2=\"{:.1}\" y2=\"{bottom:.1}\" stroke=\"#555\" stroke-width=\"1\" stroke-dasharray=\"4 3\"/>",
            bx0 - 20.0,
            bx1 + 20.0
        ));
    }
    svg.push_str("</svg>");
    let inputs = sensors.iter().filter(|s| s.input).count();
    let caption = format!(
        "Sensor layout (elevation, not to scale): {} channel(s){}; → X in the plane of the drawing, ⊙ Y out of it, ↑ vertical, \
         ↗ a compass azimuth (not on the building axes); inputs — the base motion — in orange ({inputs}).{}",
        sensors.len(),
        if has_levels {
            " by level, heights above the base where the storey heights are stated"
        } else {
            " by sensor location as the record headers name it (no levels: not a building, or levels not stated)"
        },
        if sensors.iter().any(|s| s.level.is_none()) && has_levels {
            " Channels without a level are grouped by their location."
        } else {
            ""
        }
    );
    format!(
        "<figure class=\"layout-sketch\" id=\"sensor-layout\">{svg}<figcaption>{}</figcaption></figure>",
        escape(&caption)
    )
}
